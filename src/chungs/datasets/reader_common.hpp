// Pieces every dataset reader shares: a base class holding the per-frame metadata known at open
// time, file listing, image/depth loading with shape checks, small matrix files, and ground-truth
// lookup by timestamp. Internal to the datasets module (namespace chungs::ds).
#pragma once
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/geometry/trajectory.hpp"

namespace chungs::ds {

namespace fs = std::filesystem;

// A reader whose timestamps and ground truth are all read when it opens; only images are loaded
// lazily by frame(i).
class SequenceDataset : public Dataset {
 public:
  const DatasetInfo& info() const override { return info_; }
  double timestamp(size_t i) const override;
  std::optional<SE3> gt_pose(size_t i) const override;

 protected:
  // Ends a reader's constructor: sets the frame count and has_gt. `gt` is empty (no ground truth) or
  // has one entry per stamp.
  void finish(std::vector<double> stamps, std::vector<std::optional<SE3>> gt);
  void check_index(size_t i) const;
  // A Frame with everything but the images filled in.
  Frame frame_header(size_t i, const fs::path& source) const;

  DatasetInfo info_;

 private:
  std::vector<double> stamps_;
  std::vector<std::optional<SE3>> gt_;
};

// Files in `dir` named PREFIX<digits>SUFFIX, as (number, path) sorted by number. Other names are
// ignored; two files with the same number are an error.
std::vector<std::pair<long long, fs::path>> numbered_files(const fs::path& dir, const std::string& prefix,
                                                           const std::string& suffix);

// `dir` itself when dir/child exists, its parent when `dir` is the child folder itself, else the single
// subfolder of `dir` that has `child`.
fs::path folder_with(const fs::path& dir, const std::string& child, const std::string& what);
// The folder a path names, without a trailing separator ("a/mav0/" -> "a/mav0").
fs::path named_folder(const fs::path& p);

// First of `candidates` that exists as a file, or nullopt.
std::optional<fs::path> first_existing(const std::vector<fs::path>& candidates);

// Reads an 8-bit image as gray or RGB (alpha dropped) and checks its size (when width > 0) and
// channel count (when channels > 0) against the sequence's, naming the file when they differ.
Image8 load_image(const fs::path& file, int width = 0, int height = 0, int channels = 0);
// Reads a 16-bit depth PNG as metres (value / units_per_metre; 0 stays 0 = invalid) and checks its size.
ImageF load_depth(const fs::path& file, double units_per_metre, int width, int height);

// A text file holding exactly rows x cols numbers, one matrix row per line.
Eigen::MatrixXd read_matrix(const fs::path& file, int rows, int cols);

// Ground truth for each stamp: interpolated between the two samples around it when both lie within
// max_dt, else the nearest sample within max_dt, else none. `gt` stamps must increase.
std::vector<std::optional<SE3>> poses_at(const Trajectory& gt, const std::vector<double>& stamps, double max_dt);

// Throws "FILE: WHAT must be positive, got V" unless v is finite and > 0.
double require_positive(double v, const fs::path& file, const std::string& what);
// An image side read as a number: whole and in [1, kMaxImagePixels], checked before it becomes an
// int (converting a larger double is undefined behaviour). Throws naming the file and WHAT.
int require_pixels(double v, const fs::path& file, const std::string& what);

}  // namespace chungs::ds
