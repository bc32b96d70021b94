// Dataset: random access to the frames of a sequence on disk, named on the CLI as `kind:path`.
#pragma once
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "chungs/datasets/frame.hpp"

namespace chungs {

struct DatasetInfo {
  std::string kind;             // kitti, tum, replica, euroc, 3dmatch
  std::filesystem::path path;
  size_t frames = 0;
  Camera camera;                // left camera after rectification/undistortion
  double baseline = 0;          // metres, stereo only
  bool has_right = false, has_depth = false, has_gt = false;
  bool color = false;           // left images are RGB
  double rate_hz = 0;           // nominal frame rate
};

class Dataset {
 public:
  virtual ~Dataset() = default;
  virtual const DatasetInfo& info() const = 0;
  size_t size() const { return info().frames; }
  // Loads frame i's images from disk; throws Error naming the file at fault.
  virtual Frame frame(size_t i) const = 0;
  // Metadata without loading images.
  virtual double timestamp(size_t i) const = 0;
  virtual std::optional<SE3> gt_pose(size_t i) const = 0;
};

// Opens "kind:path" (kinds: kitti, tum, replica, euroc, 3dmatch). Throws Error for an unknown kind
// or a missing, corrupt or inconsistent dataset, naming the file and line.
std::unique_ptr<Dataset> open_dataset(const std::string& spec);
std::vector<std::string> dataset_kinds();

// Length of the ground-truth path: sum of distances between the positions of consecutive frames
// that have a ground-truth pose (frames without one are skipped, not counted as gaps of zero).
double gt_path_length(const Dataset& dataset);

}  // namespace chungs
