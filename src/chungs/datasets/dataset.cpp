#include "chungs/datasets/dataset.hpp"

#include <functional>
#include <utility>

#include "chungs/common/log.hpp"
#include "chungs/datasets/readers.hpp"
#include "chungs/datasets/rosbag_reader.hpp"

namespace chungs {

namespace {

using Opener = std::function<std::unique_ptr<Dataset>(const std::filesystem::path&)>;

const std::vector<std::pair<std::string, Opener>>& openers() {
  static const std::vector<std::pair<std::string, Opener>> list = {
      {"kitti", ds::open_kitti},     {"tum", ds::open_tum},         {"replica", ds::open_replica},
      {"euroc", ds::open_euroc},     {"3dmatch", ds::open_3dmatch},
  };
  return list;
}

std::string kinds_list() {
  std::string s;
  for (const auto& k : dataset_kinds()) s += (s.empty() ? "" : ", ") + k;
  return s;
}

}  // namespace

std::vector<std::string> dataset_kinds() {
  std::vector<std::string> out;
  for (const auto& [name, open] : openers()) out.push_back(name);
  out.push_back("rosbag");
  return out;
}

std::unique_ptr<Dataset> open_dataset(const std::string& spec) {
  auto colon = spec.find(':');
  if (colon == std::string::npos)
    fail("dataset '", spec, "': expected KIND:PATH with KIND one of ", kinds_list());
  std::string kind = spec.substr(0, colon);
  std::filesystem::path path = spec.substr(colon + 1);
  if (path.empty()) fail("dataset '", spec, "': the path after '", kind, ":' is empty");
  // A bag is a file with topics after '?', not a folder.
  if (kind == "rosbag") return ds::open_rosbag(spec.substr(colon + 1));
  for (const auto& [name, open] : openers()) {
    if (name != kind) continue;
    require_dir(path, cat(kind, " dataset folder"));
    // Readers look at the folder's own name (TUM's freiburgN, KITTI's sequence number): make it
    // absolute and drop a trailing slash so that name is never empty or ".".
    std::filesystem::path folder = std::filesystem::absolute(path).lexically_normal();
    if (!folder.has_filename()) folder = folder.parent_path();
    auto dataset = open(folder);
    const auto& in = dataset->info();
    log::info("opened ", kind, ":", in.path.string(), ": ", in.frames, " frames, ", in.camera.width, "x",
              in.camera.height, in.has_right ? ", stereo" : "", in.has_depth ? ", depth" : "",
              in.has_gt ? ", ground truth" : "");
    return dataset;
  }
  fail("dataset '", spec, "': unknown kind '", kind, "' (known: ", kinds_list(), ")");
}

double gt_path_length(const Dataset& dataset) {
  double length = 0;
  std::optional<SE3> prev;
  for (size_t i = 0; i < dataset.size(); ++i) {
    auto pose = dataset.gt_pose(i);
    if (!pose) continue;
    if (prev) length += (pose->t - prev->t).norm();
    prev = pose;
  }
  return length;
}

}  // namespace chungs
