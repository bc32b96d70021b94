// Replica in the NICE-SLAM layout: SEQ/results/frameNNNNNN.jpg + depthNNNNNN.png, SEQ/traj.txt
// (one row-major 4x4 camera-to-world per line, line n for frame n), cam_params.json in SEQ or its
// parent. The path may also be the parent holding one sequence folder.
#include <nlohmann/json.hpp>

#include "chungs/common/log.hpp"
#include "chungs/common/text_file.hpp"
#include "chungs/datasets/reader_common.hpp"
#include "chungs/datasets/readers.hpp"

namespace chungs::ds {

namespace {

// Replica renders have no clock; NICE-SLAM-style pipelines treat them as a 30 Hz video.
constexpr double kNominalRateHz = 30;

struct Intrinsics {
  Camera camera;
  double depth_scale = 0;  // depth PNG units per metre
};

// NICE-SLAM's published Replica settings, used when no cam_params.json is there.
Intrinsics default_intrinsics() { return {Camera(1200, 680, 600.0, 600.0, 599.5, 339.5), 6553.5}; }

Intrinsics read_cam_params(const fs::path& file) {
  nlohmann::json j;
  try {
    const std::string text = read_file_text(file);
    require_json_nesting(text, file);
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail(file.string(), ": invalid JSON (", e.what(), ")");
  }
  if (!j.contains("camera") || !j["camera"].is_object()) fail(file.string(), ": no \"camera\" object");
  const auto& c = j["camera"];
  auto num = [&](const char* key) -> double {
    if (!c.contains(key) || !c[key].is_number()) fail(file.string(), ": camera.", key, " is missing or not a number");
    return c[key].get<double>();
  };
  Intrinsics in;
  const int w = require_pixels(num("w"), file, "camera.w");
  const int h = require_pixels(num("h"), file, "camera.h");
  in.camera = Camera(w, h, require_positive(num("fx"), file, "camera.fx"),
                     require_positive(num("fy"), file, "camera.fy"), num("cx"), num("cy"));
  in.depth_scale = c.contains("scale") ? require_positive(num("scale"), file, "camera.scale") : 6553.5;
  in.camera.validate(file.string());
  return in;
}

class ReplicaDataset : public SequenceDataset {
 public:
  explicit ReplicaDataset(const fs::path& path) {
    fs::path dir = folder_with(path, "results", "Replica sequence folder");
    info_.kind = "replica";
    info_.path = dir;
    Intrinsics in = default_intrinsics();
    if (auto file = first_existing({dir / "cam_params.json", dir.parent_path() / "cam_params.json"})) {
      in = read_cam_params(*file);
    } else {
      log::warn(dir.string(), ": no cam_params.json here or in the parent; using NICE-SLAM's Replica intrinsics");
    }
    depth_scale_ = in.depth_scale;

    fs::path results = dir / "results";
    auto colour = numbered_files(results, "frame", ".jpg");
    if (colour.empty()) colour = numbered_files(results, "frame", ".png");
    if (colour.empty()) fail(results.string(), ": no frameNNNNNN.jpg (or .png) images");
    auto depth = numbered_files(results, "depth", ".png");

    fs::path traj_file = dir / "traj.txt";
    require_file(traj_file, "Replica trajectory");
    Trajectory traj = read_kitti_trajectory(traj_file);

    std::vector<double> stamps;
    std::vector<std::optional<SE3>> gt;
    size_t d = 0;
    for (const auto& [n, file] : colour) {
      while (d < depth.size() && depth[d].first < n) ++d;
      if (d == depth.size() || depth[d].first != n)
        fail(file.string(), ": no depth image numbered ", n, " (depthNNNNNN.png) beside it");
      if (size_t(n) >= traj.size())
        fail(file.string(), ": frame ", n, " has no pose (", traj_file.string(), " has ", traj.size(), " lines)");
      colour_.push_back(file);
      depth_.push_back(depth[d].second);
      stamps.push_back(double(n) / kNominalRateHz);
      gt.push_back(traj.poses[size_t(n)]);
    }

    Image8 first = load_image(colour_[0]);
    if (first.width() != in.camera.width || first.height() != in.camera.height)
      fail(colour_[0].string(), ": image is ", first.width(), "x", first.height(), " but cam_params.json says ",
           in.camera.width, "x", in.camera.height);
    in.camera.validate(dir.string() + " camera");
    channels_ = first.channels();
    info_.camera = in.camera;
    info_.has_depth = true;
    info_.color = channels_ == 3;
    info_.rate_hz = kNominalRateHz;
    finish(stamps, gt);
  }

  Frame frame(size_t i) const override {
    check_index(i);
    Frame f = frame_header(i, colour_[i]);
    const Camera& c = info_.camera;
    f.left = load_image(colour_[i], c.width, c.height, channels_);
    f.depth = load_depth(depth_[i], depth_scale_, c.width, c.height);
    return f;
  }

 private:
  std::vector<fs::path> colour_, depth_;
  double depth_scale_ = 0;
  int channels_ = 3;
};

}  // namespace

std::unique_ptr<Dataset> open_replica(const fs::path& path) { return std::make_unique<ReplicaDataset>(path); }

}  // namespace chungs::ds
