// EuRoC MAV: mav0/cam0 and mav0/cam1, each with data.csv ("t[ns],file"), data/*.png and sensor.yaml
// (pinhole + radial-tangential, T_BS body-from-sensor). The distorted pair is rectified with
// OpenCV; frames carry the rectified left camera, and ground truth (body poses) is moved into it.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "chungs/common/log.hpp"
#include "chungs/common/text_file.hpp"
#include "chungs/datasets/reader_common.hpp"
#include "chungs/datasets/readers.hpp"
#include "chungs/datasets/remap.hpp"

namespace chungs::ds {

namespace {

constexpr double kMaxStereoDt = 0.0025;  // s; both cameras are triggered together
constexpr double kMaxGtDt = 0.01;

struct Sensor {
  Camera camera;  // with distortion
  SE3 T_BS;       // sensor to body
  double rate_hz = 0;
  std::vector<double> stamps;
  std::vector<fs::path> files;
};

std::vector<double> yaml_numbers(const YAML::Node& root, const char* key, size_t n_min, size_t n_max,
                                 const fs::path& file) {
  YAML::Node node = root[key];
  if (node && node.IsMap()) node = node["data"];  // OpenCV-style matrix {rows, cols, data}
  if (!node || !node.IsSequence()) fail(file.string(), ": '", key, "' is missing or not a list");
  if (node.size() < n_min || node.size() > n_max)
    fail(file.string(), ": '", key, "' has ", node.size(), " values, expected ", n_min,
         n_min == n_max ? "" : cat(" to ", n_max));
  std::vector<double> out;
  for (const auto& v : node) out.push_back(parse_double(v.as<std::string>(), cat(file.string(), ": ", key)));
  return out;
}

Sensor read_sensor(const fs::path& dir) {
  Sensor s;
  fs::path file = dir / "sensor.yaml";
  std::string text = read_file_text(file);
  // OpenCV's "%YAML:1.0" directive is not valid YAML 1.2; yaml-cpp rejects it. Blank the line so
  // line numbers in messages stay right.
  if (text.rfind("%YAML", 0) == 0) text.erase(0, text.find('\n'));
  YAML::Node root;
  try {
    root = YAML::Load(text);
    auto intr = yaml_numbers(root, "intrinsics", 4, 4, file);
    auto res = yaml_numbers(root, "resolution", 2, 2, file);
    auto dist = yaml_numbers(root, "distortion_coefficients", 4, 5, file);
    auto T = yaml_numbers(root, "T_BS", 16, 16, file);
    std::string model = root["distortion_model"] ? root["distortion_model"].as<std::string>() : "radial-tangential";
    if (model != "radial-tangential" && model != "radtan")
      fail(file.string(), ": distortion model '", model, "' is not supported (radial-tangential only)");
    std::string cam_model = root["camera_model"] ? root["camera_model"].as<std::string>() : "pinhole";
    if (cam_model != "pinhole") fail(file.string(), ": camera model '", cam_model, "' is not supported (pinhole only)");
    s.camera = Camera(
        require_pixels(res[0], file, "resolution width"), require_pixels(res[1], file, "resolution height"),
        require_positive(intr[0], file, "fu"), require_positive(intr[1], file, "fv"), intr[2], intr[3]);
    for (size_t k = 0; k < dist.size(); ++k) s.camera.dist[k] = dist[k];
    s.camera.validate(file.string());  // here, naming the file: the rectified camera's message named none
    s.T_BS = SE3::from_matrix(Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(T.data()),
                              cat(file.string(), ": T_BS").c_str());
    s.rate_hz = root["rate_hz"] ? require_positive(root["rate_hz"].as<double>(), file, "rate_hz") : 20.0;
  } catch (const YAML::Exception& e) {
    fail(file.string(), ":", e.mark.line + 1, ": ", e.msg);
  }
  for (const auto& l : read_text_table(dir / "data.csv", true)) {
    l.expect_fields(2);
    long long ns = l.integer_at(0);
    if (ns < 0) l.fail_here(cat("timestamp ", ns, " is negative"));
    s.stamps.push_back(double(ns) * 1e-9);
    s.files.push_back(dir / "data" / l.tokens[1]);
  }
  if (s.stamps.empty()) fail((dir / "data.csv").string(), ": lists no images");
  return s;
}

// Body trajectory: the EuRoC ground-truth csv (t[ns], p xyz, q wxyz, ...) or a TUM file in
// groundtruth/ (as the converted ground truth that tools such as OpenVINS ship).
std::optional<Trajectory> read_body_gt(const fs::path& root, const fs::path& mav) {
  fs::path csv = mav / "state_groundtruth_estimate0" / "data.csv";
  if (fs::exists(csv)) {
    Trajectory tr;
    for (const auto& l : read_text_table(csv, true)) {
      l.expect_fields(8, true);
      Eigen::Quaterniond q(l.number_at(4), l.number_at(5), l.number_at(6), l.number_at(7));
      if (std::abs(q.norm() - 1) > 1e-2) l.fail_here(cat("quaternion is not unit length (norm ", q.norm(), ")"));
      double t = double(l.integer_at(0)) * 1e-9;
      if (!tr.empty() && !(t > tr.stamps.back())) l.fail_here("timestamp does not increase");
      tr.push_back(t, SE3(q.normalized(), Eigen::Vector3d(l.number_at(1), l.number_at(2), l.number_at(3))));
    }
    if (tr.empty()) fail(csv.string(), ": no poses");
    return tr;
  }
  std::vector<fs::path> tum;
  std::error_code ec;
  if (fs::is_directory(root / "groundtruth", ec))
    for (const auto& e : fs::directory_iterator(root / "groundtruth", ec))
      if (e.is_regular_file() && e.path().extension() == ".txt") tum.push_back(e.path());
  if (tum.empty()) return std::nullopt;
  if (tum.size() > 1) fail((root / "groundtruth").string(), ": several .txt trajectories; keep one");
  return read_tum_trajectory(tum[0]);
}

class EurocDataset : public SequenceDataset {
 public:
  explicit EurocDataset(const fs::path& root) {
    fs::path mav = fs::exists(root / "mav0") ? root / "mav0" : root;
    const fs::path folder = named_folder(root);
    if ((folder.filename() == "cam0" || folder.filename() == "cam1") && !fs::exists(root / "cam0"))
      fail(root.string(), " is one camera's folder: give the EuRoC sequence folder that holds mav0/ (or mav0/ itself)");
    require_dir(mav / "cam0", "EuRoC cam0 folder");
    require_dir(mav / "cam1", "EuRoC cam1 folder");
    info_.kind = "euroc";
    info_.path = root;
    Sensor c0 = read_sensor(mav / "cam0");
    Sensor c1 = read_sensor(mav / "cam1");
    if (c0.camera.width != c1.camera.width || c0.camera.height != c1.camera.height)
      fail((mav / "cam1" / "sensor.yaml").string(), ": resolution differs from cam0's");

    std::vector<double> stamps;
    for (auto [i, j] : associate_stamps(c0.stamps, c1.stamps, kMaxStereoDt)) {
      require_file(c0.files[i], "cam0 image listed in data.csv");
      require_file(c1.files[j], "cam1 image listed in data.csv");
      stamps.push_back(c0.stamps[i]);
      left_.push_back(c0.files[i]);
      right_.push_back(c1.files[j]);
    }
    if (stamps.empty()) fail(mav.string(), ": no cam0 image has a cam1 image with the same timestamp");
    if (stamps.size() < c0.stamps.size())
      log::info(mav.string(), ": ", c0.stamps.size() - stamps.size(), " cam0 images have no cam1 partner; skipped");

    Eigen::Matrix3d R_rect = rectify(c0, c1, mav / "cam1" / "sensor.yaml");
    channels_ = load_image(left_[0], c0.camera.width, c0.camera.height).channels();
    info_.has_right = true;
    info_.color = channels_ == 3;
    info_.rate_hz = c0.rate_hz;

    std::vector<std::optional<SE3>> gt;
    // Given mav0/ itself, the sequence folder above it may hold groundtruth/.
    const fs::path base = mav == root && folder.filename() == "mav0" ? folder.parent_path() : root;
    if (auto body = read_body_gt(base, mav)) {
      // Body -> unrectified cam0 (T_BS) -> rectified cam0 (rotation R_rect applied to camera points).
      SE3 body_to_cam = c0.T_BS * SE3(R_rect.transpose(), Eigen::Vector3d::Zero());
      gt = poses_at(*body, stamps, kMaxGtDt);
      for (auto& p : gt)
        if (p) p = *p * body_to_cam;
    } else {
      log::info(root.string(), ": no ground truth (state_groundtruth_estimate0/data.csv or groundtruth/*.txt)");
    }
    finish(stamps, gt);
  }

  Frame frame(size_t i) const override {
    check_index(i);
    Frame f = frame_header(i, left_[i]);
    const Camera& c = raw_size_;
    f.left = map_left_.apply(load_image(left_[i], c.width, c.height, channels_));
    f.right = map_right_.apply(load_image(right_[i], c.width, c.height, channels_));
    return f;
  }

 private:
  // Builds both rectification maps and the rectified left camera; returns the left rectifying
  // rotation (unrectified cam0 points -> rectified cam0 points).
  Eigen::Matrix3d rectify(const Sensor& c0, const Sensor& c1, const fs::path& cam1_yaml) {
    raw_size_ = c0.camera;
    // OpenCV wants cam1 <- cam0: x1 = R x0 + T.
    SE3 c1_from_c0 = c1.T_BS.inverse() * c0.T_BS;
    Eigen::Matrix3d Re = c1_from_c0.rotation();
    cv::Mat R(3, 3, CV_64F), T(3, 1, CV_64F);
    for (int r = 0; r < 3; ++r) {
      T.at<double>(r) = c1_from_c0.t[r];
      for (int k = 0; k < 3; ++k) R.at<double>(r, k) = Re(r, k);
    }
    cv::Size size(c0.camera.width, c0.camera.height);
    cv::Mat K0 = camera_matrix(c0.camera), K1 = camera_matrix(c1.camera), D0 = dist_coeffs(c0.camera),
            D1 = dist_coeffs(c1.camera), R1, R2, P1, P2, Q;
    // alpha 0: crop to pixels valid in both images, so no black borders reach the mapper.
    cv::stereoRectify(K0, D0, K1, D1, size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0);
    cv::Mat m1, m2, n1, n2;
    cv::initUndistortRectifyMap(K0, D0, R1, P1, size, CV_32FC1, m1, m2);
    cv::initUndistortRectifyMap(K1, D1, R2, P2, size, CV_32FC1, n1, n2);
    map_left_ = Remap(m1, m2);
    map_right_ = Remap(n1, n2);
    require_coverage(map_left_, size.width, size.height, (cam1_yaml.parent_path().parent_path() / "cam0" / "sensor.yaml").string());
    require_coverage(map_right_, size.width, size.height, cam1_yaml.string());

    Camera rect(size.width, size.height, P1.at<double>(0, 0), P1.at<double>(1, 1), P1.at<double>(0, 2),
                P1.at<double>(1, 2));
    rect.validate(info_.path.string() + " rectified camera");
    info_.camera = rect;
    info_.baseline = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
    if (!(info_.baseline > 0))
      fail(cam1_yaml.string(), ": cam1 is not to the right of cam0 (baseline ",
           info_.baseline, " m after rectification)");
    Eigen::Matrix3d out;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) out(r, k) = R1.at<double>(r, k);
    return out;
  }

  std::vector<fs::path> left_, right_;
  Camera raw_size_;
  Remap map_left_, map_right_;
  int channels_ = 1;
};

}  // namespace

std::unique_ptr<Dataset> open_euroc(const fs::path& path) { return std::make_unique<EurocDataset>(path); }

}  // namespace chungs::ds
