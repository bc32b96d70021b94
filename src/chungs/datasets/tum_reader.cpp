// TUM RGB-D: rgb.txt / depth.txt index files ("stamp file" per line), depth PNGs in units of
// 1/5000 m registered to the colour camera, groundtruth.txt in TUM trajectory format. The
// Freiburg cameras' intrinsics are known by the folder name; colour and depth are undistorted
// with the same map so Frame.camera has no distortion and depth stays aligned with colour.
#include <iomanip>

#include "chungs/common/log.hpp"
#include "chungs/common/text_file.hpp"
#include "chungs/datasets/reader_common.hpp"
#include "chungs/datasets/readers.hpp"
#include "chungs/datasets/remap.hpp"

namespace chungs::ds {

namespace {

constexpr double kDepthUnitsPerMetre = 5000;
constexpr double kMaxRgbDepthDt = 0.02;  // s, as TUM's associate.py
constexpr double kMaxGtDt = 0.02;

struct Indexed {
  std::vector<double> stamps;
  std::vector<fs::path> files;
};

Indexed read_index(const fs::path& dir, const std::string& name) {
  fs::path file = dir / name;
  require_file(file, "TUM index file");
  Indexed out;
  int previous_line = 0;
  for (const auto& l : read_text_table(file)) {
    l.expect_fields(2);
    double t = l.number_at(0);
    if (t < 0) l.fail_here(cat("timestamp ", t, " is negative"));
    // Frames are mapped in the order listed: one out of time order would be mapped out of time.
    if (!out.stamps.empty() && !(t > out.stamps.back()))
      l.fail_here(cat("timestamp ", std::fixed, std::setprecision(6), t, " is not after ", out.stamps.back(),
                      " on line ", previous_line, "; frames must be listed in time order"));
    previous_line = l.number;
    // Here, not when the frame is read: inspect counted such a frame, and a run stopped at it hours in.
    std::error_code ec;
    if (!fs::is_regular_file(dir / l.tokens[1], ec))
      l.fail_here(cat((dir / l.tokens[1]).string(), " is not a file", ec ? " (" + ec.message() + ")" : std::string()));
    out.stamps.push_back(t);
    out.files.push_back(dir / l.tokens[1]);
  }
  if (out.stamps.empty()) fail(file.string(), ": lists no images");
  return out;
}

// Published calibration of the three Freiburg Kinects (TUM RGB-D "file formats" page), by the
// folder name rgbd_dataset_freiburgN_...; other folders get the Kinect's nominal default.
Camera freiburg_camera(const fs::path& dir) {
  std::string name = dir.filename().string();
  Camera c(640, 480, 525.0, 525.0, 319.5, 239.5);
  if (name.find("freiburg1") != std::string::npos) {
    c = Camera(640, 480, 517.3, 516.5, 318.6, 255.3);
    c.dist = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  } else if (name.find("freiburg2") != std::string::npos) {
    c = Camera(640, 480, 520.9, 521.0, 325.1, 249.7);
    c.dist = {0.2312, -0.7849, -0.0033, -0.0001, 0.9172};
  } else if (name.find("freiburg3") != std::string::npos) {
    c = Camera(640, 480, 535.4, 539.2, 320.1, 247.6);
  } else if (!fs::exists(dir / "calib.txt")) {
    log::info(dir.string(), ": folder name does not say freiburg1/2/3 and there is no calib.txt; using default ",
              "intrinsics 525/525/319.5/239.5");
  }
  return c;
}

// Optional override: calib.txt with one line "fx fy cx cy [k1 k2 p1 p2 [k3]]".
void apply_override(const fs::path& file, Camera& c) {
  auto lines = read_text_table(file);
  if (lines.size() != 1) fail(file.string(), ": expected one line 'fx fy cx cy [k1 k2 p1 p2 [k3]]', found ", lines.size());
  const auto& l = lines[0];
  size_t n = l.tokens.size();
  if (n != 4 && n != 8 && n != 9) l.fail_here(cat("expected 4, 8 or 9 numbers (fx fy cx cy [k1 k2 p1 p2 [k3]]), found ", n));
  c.fx = l.number_at(0);
  c.fy = l.number_at(1);
  c.cx = l.number_at(2);
  c.cy = l.number_at(3);
  if (!(c.fx > 0 && c.fy > 0)) l.fail_here("focal lengths must be positive");
  c.dist = {0, 0, 0, 0, 0};
  for (size_t k = 4; k < n; ++k) c.dist[k - 4] = l.number_at(k);
}

class TumDataset : public SequenceDataset {
 public:
  explicit TumDataset(const fs::path& dir) {
    info_.kind = "tum";
    info_.path = dir;
    Indexed rgb = read_index(dir, "rgb.txt");
    Indexed depth = read_index(dir, "depth.txt");
    std::vector<double> stamps;
    for (auto [i, j] : associate_stamps(rgb.stamps, depth.stamps, kMaxRgbDepthDt)) {
      stamps.push_back(rgb.stamps[i]);
      rgb_.push_back(rgb.files[i]);
      depth_.push_back(depth.files[j]);
    }
    if (stamps.empty())
      fail(dir.string(), ": no rgb.txt entry has a depth.txt entry within ", kMaxRgbDepthDt, " s");
    if (stamps.size() < rgb.stamps.size())
      log::info(dir.string(), ": ", rgb.stamps.size() - stamps.size(), " colour images have no depth and are skipped");

    Camera cam = freiburg_camera(dir);
    if (auto file = first_existing({dir / "calib.txt"})) apply_override(*file, cam);
    Image8 first = load_image(rgb_[0]);
    cam.width = first.width();
    cam.height = first.height();
    cam.validate(dir.string() + " camera");
    channels_ = first.channels();
    if (cam.distorted()) {
      undistort_ = undistortion(cam);
      require_coverage(undistort_, cam.width, cam.height, dir.string() + " camera");
    }
    cam.dist = {0, 0, 0, 0, 0};
    info_.camera = cam;
    info_.has_depth = true;
    info_.color = channels_ == 3;
    info_.rate_hz = 30;  // the Kinect's nominal rate; stamps give the true times

    std::vector<std::optional<SE3>> gt;
    if (auto file = first_existing({dir / "groundtruth.txt"}))
      gt = poses_at(read_tum_trajectory(*file), stamps, kMaxGtDt);
    else
      log::info(dir.string(), ": no groundtruth.txt; no ground truth");
    finish(stamps, gt);
  }

  Frame frame(size_t i) const override {
    check_index(i);
    Frame f = frame_header(i, rgb_[i]);
    const Camera& c = info_.camera;
    f.left = load_image(rgb_[i], c.width, c.height, channels_);
    ImageF depth = load_depth(depth_[i], kDepthUnitsPerMetre, c.width, c.height);
    if (!undistort_.empty()) {
      f.left = undistort_.apply(f.left);
      depth = undistort_.apply_nearest(depth);
    }
    f.depth = std::move(depth);
    return f;
  }

 private:
  std::vector<fs::path> rgb_, depth_;
  int channels_ = 3;
  Remap undistort_;  // empty when the camera has no distortion
};

}  // namespace

std::unique_ptr<Dataset> open_tum(const fs::path& path) { return std::make_unique<TumDataset>(path); }

}  // namespace chungs::ds
