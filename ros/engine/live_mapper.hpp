// LiveMapper: the mapper fed frame by frame from a live source (the ROS node), behind plain
// structs: the node is C++17 (ROS 1 headers), the library C++20, and this header is all they share.
// One thread maps; the node's callbacks only queue frames and ask for renders, clouds and status.
#pragma once
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "chungs/datasets/rosbag_io.hpp"

namespace chungs::live {

struct Settings {
  std::string out;  // map folder (created, or reopened with resume)
  bool resume = false;
  std::string preset = "indoor";  // outdoor | indoor: the run presets of `diskchungs run`
  std::string config_yaml;        // mapper settings as YAML, the keys of `diskchungs info --config`
  std::string device = "auto";    // auto | cuda | cpu, as `diskchungs run --device`
  std::string source = "ros";     // names the input in the map's run state
  // Frames waiting to be mapped at most, the oldest dropped first; 0: no bound; -1: automatic (anytime
  // pacing with given poses: mapper.frame_lookahead, at least 1; fixed pacing or the tracker: no bound).
  long max_queue = -1;
  bool track = false;  // poses from the project's visual tracker (as `run --poses track`)
};

struct LiveFrame {
  double stamp = 0;
  rosbag_io::Picture left;                  // 8-bit gray or RGB, rectified
  std::optional<rosbag_io::Picture> right;  // stereo
  std::optional<rosbag_io::Picture> depth;  // RGB-D: metres, registered to `left`
  double fx = 0, fy = 0, cx = 0, cy = 0;    // rectified camera of `left`
  double baseline = 0;                      // stereo, metres
  std::optional<rosbag_io::Pose> pose;      // camera-to-world (optical frame); none with Settings::track
};

struct Status {
  uint64_t frames = 0, keyframes = 0, iterations = 0, gaussians = 0, resident = 0, budget = 0, chunks = 0;
  uint64_t queued = 0, dropped = 0, corrected = 0;  // corrected: keyframes moved by correct()
  uint64_t without_pose = 0;                        // frames skip() counted
  double io_wait_ms = 0, steps_per_s = 0, seconds = 0;
  // The fewest steps a keyframe got before the next one came (-1 until a second keyframe): under anytime
  // pacing at least mapper.min_steps_per_keyframe.
  int64_t least_steps_per_keyframe = -1;
  std::string error;  // the mapping thread's failure, if it stopped on one
};

// The process settings `diskchungs` starts with (one malloc arena, so that host memory stays flat over
// a long drive; OpenCV off OpenCL): call first in main(), before any thread. Returns the allocator's
// description for the node's start line.
std::string set_process_defaults();

class LiveMapper {
 public:
  explicit LiveMapper(const Settings& settings);  // throws chungs::Error for bad settings or folder
  ~LiveMapper();                                  // finish() if not called
  LiveMapper(const LiveMapper&) = delete;
  LiveMapper& operator=(const LiveMapper&) = delete;

  void push(LiveFrame frame);
  // A frame that arrived without a pose: it keeps its number (held-out frames stay where `run` has
  // them) and is counted, but not mapped.
  void skip();
  // The map rendered from the latest keyframe's pose at the mapping resolution (RGB), if any.
  std::optional<rosbag_io::Picture> render_latest();
  // Centres (x y z ...) of the Gaussians of the committed map in chunks within `radius` metres of the
  // latest keyframe: the chunks the mapper keeps resident around the camera.
  std::vector<float> centres(double radius);
  std::vector<rosbag_io::Pose> keyframe_poses();
  // An external localisation's corrected camera poses (camera-to-world) by stamp, e.g. after its loop
  // closure: the keyframes at those stamps take them, their Gaussians move along between chunks
  // (Mapper::correct_poses), and the map commits. Changes below mapper.pose_update_min_* are ignored.
  // Returns how many keyframes moved.
  size_t correct(const std::vector<std::pair<double, rosbag_io::Pose>>& poses);
  Status status();
  void checkpoint();
  // Commits, then writes the map (or the Gaussians inside box = {x0 y0 z0 x1 y1 z1}) as a 3DGS PLY.
  uint64_t export_ply(const std::string& file, const std::vector<double>& box);
  // Maps the frames still queued, refines (mapper.final_iterations), commits the finished map.
  void finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace chungs::live
