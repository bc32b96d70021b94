// Timestamped pose sequences and their TUM / KITTI text formats (the formats the evo tool reads).
#pragma once
#include <filesystem>
#include <string>
#include <vector>

#include "chungs/geometry/se3.hpp"

namespace chungs {

struct Trajectory {
  std::vector<double> stamps;  // seconds, same length as poses
  std::vector<SE3> poses;      // camera-to-world

  size_t size() const { return poses.size(); }
  bool empty() const { return poses.empty(); }
  void push_back(double t, const SE3& pose) {
    stamps.push_back(t);
    poses.push_back(pose);
  }
  double path_length() const;  // sum of distances between consecutive positions
};

enum class TrajectoryFormat { Tum, Kitti };

// TUM: "t tx ty tz qx qy qz qw" per line, '#' comments. KITTI: 12 numbers per line (row-major 3x4
// camera-to-world); stamps are taken from `kitti_stamps` when given (must match in count), else
// i / kitti_rate_hz. Errors name the file and line.
Trajectory read_tum_trajectory(const std::filesystem::path& file);
Trajectory read_kitti_trajectory(const std::filesystem::path& file, const std::vector<double>& kitti_stamps = {},
                                 double kitti_rate_hz = 10.0);
// By content: 8 fields per line -> TUM, 12 -> KITTI (16 -> 4x4 row-major, as Replica's traj.txt).
Trajectory read_trajectory(const std::filesystem::path& file, double rate_hz_if_unstamped = 10.0);

// monocular: the trajectory comes from one camera, whose scale is the tracker's own: the file then
// begins with kMonocularTrajectoryComment (a '#' line, which both formats' readers here and evo's
// skip), and `eval ate` aligns it with Sim(3) by itself.
void write_tum_trajectory(const std::filesystem::path& file, const Trajectory& traj, bool monocular = false);
void write_kitti_trajectory(const std::filesystem::path& file, const Trajectory& traj, bool monocular = false);
void write_trajectory(const std::filesystem::path& file, const Trajectory& traj, TrajectoryFormat format,
                      bool monocular = false);
inline constexpr const char* kMonocularTrajectoryComment =
    "# input: mono (one camera: the scale is the tracker's own, align with sim3)";
// Whether the comment lines before the file's first pose include one that begins "# input: mono".
// Throws Error naming the file when it cannot be read.
bool trajectory_is_monocular(const std::filesystem::path& file);
TrajectoryFormat parse_trajectory_format(const std::string& name);  // "tum" | "kitti"

// Pairs each stamp of `a` with the nearest stamp of `b` within max_dt seconds, each b used at most
// once (greedy in order of time difference, as evo/TUM associate do). Returns index pairs.
std::vector<std::pair<size_t, size_t>> associate_stamps(const std::vector<double>& a, const std::vector<double>& b,
                                                        double max_dt);

}  // namespace chungs
