// A ROS 1 bag as a dataset. The spec is FILE?KEY=VALUE&KEY=VALUE...:
//   stereo:  left=TOPIC&right=TOPIC[&left_info=TOPIC&right_info=TOPIC]
//   RGB-D:   color=TOPIC&depth=TOPIC[&info=TOPIC]   (depth registered to the colour camera)
//   mono:    left=TOPIC[&left_info=TOPIC]
//   poses:   [world=FRAME][&camera=FRAME]  ground truth from the bag's /tf and /tf_static: the camera
//            frame (default: the images' frame_id, an optical frame) in the world frame (default
//            "world" when tf has it)
//   pairing: [sync=SECONDS]  the two images of a frame within this of each other (default 0.02)
// camera_info topics default to camera_info beside the image topic. Images that are not rectified
// (distortion or a rectifying rotation in camera_info) are rectified to camera_info's P here.
#include "chungs/datasets/rosbag_reader.hpp"

#include <cmath>
#include <filesystem>
#include <map>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/datasets/rosbag_images.hpp"
#include "chungs/datasets/rosbag_io.hpp"

#ifdef CHUNGS_WITH_ROS
#include <opencv2/calib3d.hpp>

#include "chungs/datasets/reader_common.hpp"
#include "chungs/datasets/remap.hpp"
#endif

namespace chungs::ds {

namespace {

struct BagSpec {
  std::string file;
  rosbag_io::Topics topics;
};

double parse_seconds(const std::string& text, const std::string& spec) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v) || v < 0 || v > 10)
    fail("rosbag:", spec, ": sync=", text, " is not a number of seconds in [0, 10]");
  return v;
}

BagSpec parse_spec(const std::string& spec) {
  BagSpec out;
  const auto q = spec.find('?');
  out.file = spec.substr(0, q);
  if (out.file.empty()) fail("rosbag:", spec, ": the bag file before '?' is empty");
  // The file first: a mistyped path is the likelier mistake than missing topics.
  if (std::error_code ec; !std::filesystem::exists(out.file, ec))
    fail("rosbag:", spec, ": bag file ", out.file, " does not exist");
  if (q == std::string::npos)
    fail("rosbag:", spec,
         ": no topics given; add ?left=TOPIC&right=TOPIC (stereo) or ?color=TOPIC&depth=TOPIC (RGB-D)");
  auto& t = out.topics;
  const std::map<std::string, std::string*> keys = {
      {"left", &t.left},    {"right", &t.right}, {"left_info", &t.left_info}, {"right_info", &t.right_info},
      {"color", &t.color},  {"depth", &t.depth}, {"info", &t.info},           {"world", &t.world},
      {"camera", &t.camera}};
  t.world.clear();  // empty: "world" when tf has it, else no ground truth
  std::string rest = spec.substr(q + 1);
  std::map<std::string, bool> seen;
  size_t start = 0;
  while (start <= rest.size()) {
    size_t amp = rest.find('&', start);
    std::string item = rest.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
    start = amp == std::string::npos ? rest.size() + 1 : amp + 1;
    if (item.empty()) continue;
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq), value = eq == std::string::npos ? "" : item.substr(eq + 1);
    if (seen[key]) fail("rosbag:", spec, ": key '", key, "' given twice");
    seen[key] = true;
    if (value.empty()) fail("rosbag:", spec, ": key '", key, "' has no value (KEY=VALUE)");
    if (key == "sync") {
      t.sync = parse_seconds(value, spec);
      continue;
    }
    auto it = keys.find(key);
    if (it == keys.end())
      fail("rosbag:", spec, ": unknown key '", key,
           "' (known: left, right, left_info, right_info, color, depth, info, world, camera, sync)");
    *it->second = value;
  }
  const bool stereo_keys =
      !t.left.empty() || !t.right.empty() || !t.left_info.empty() || !t.right_info.empty();
  const bool rgbd_keys = !t.color.empty() || !t.depth.empty() || !t.info.empty();
  if (stereo_keys && rgbd_keys)
    fail("rosbag:", spec, ": give left/right (stereo or mono) or color/depth (RGB-D), not both");
  if (!stereo_keys && !rgbd_keys) fail("rosbag:", spec, ": no image topic; give left=TOPIC or color=TOPIC");
  if (stereo_keys && t.left.empty()) fail("rosbag:", spec, ": right= needs left=");
  if (rgbd_keys && (t.color.empty() || t.depth.empty()))
    fail("rosbag:", spec, ": RGB-D needs both color= and depth=");
  if (!t.right_info.empty() && t.right.empty()) fail("rosbag:", spec, ": right_info= needs right=");
  return out;
}

#ifdef CHUNGS_WITH_ROS

bool is_identity(const std::array<double, 9>& r) {
  for (int k = 0; k < 9; ++k)
    if (std::abs(r[size_t(k)] - (k % 4 == 0 ? 1.0 : 0.0)) > 1e-9) return false;
  return true;
}

bool has_distortion(const rosbag_io::CameraInfo& info) {
  for (double d : info.D)
    if (d != 0) return true;
  return false;
}

// Maps a camera_info's raw image onto its rectified projection P (identity when already rectified).
Remap rectification(const rosbag_io::CameraInfo& info, const std::string& file) {
  // nan passed `d != 0` and the remap then blanked every pixel: a map of 0 Gaussians whose only message
  // blamed the depth.
  for (double d : info.D)
    if (!std::isfinite(d)) fail(file, ": topic ", info.topic, ": distortion coefficient ", d, " is not finite");
  for (double r : info.R)
    if (!std::isfinite(r)) fail(file, ": topic ", info.topic, ": rectification matrix R holds ", r);
  if (!has_distortion(info) && is_identity(info.R) && info.K[0] == info.P[0] && info.K[4] == info.P[5] &&
      info.K[2] == info.P[2] && info.K[5] == info.P[6])
    return {};
  cv::Mat K(3, 3, CV_64F, const_cast<double*>(info.K.data())),
      R(3, 3, CV_64F, const_cast<double*>(info.R.data()));
  cv::Mat P = (cv::Mat_<double>(3, 3) << info.P[0], info.P[1], info.P[2], info.P[4], info.P[5], info.P[6],
               info.P[8], info.P[9], info.P[10]);
  cv::Mat D(1, int(info.D.size()), CV_64F, const_cast<double*>(info.D.data())), m1, m2;
  const cv::Size size(info.width, info.height);
  if (info.distortion_model == "equidistant") {
    if (info.D.size() != 4)
      fail(file, ": topic ", info.topic, ": equidistant distortion needs 4 coefficients, has ",
           info.D.size());
    cv::fisheye::initUndistortRectifyMap(K, D, R, P, size, CV_32FC1, m1, m2);
  } else if (info.distortion_model == "plumb_bob" || info.distortion_model == "rational_polynomial" ||
             info.D.empty()) {
    if (!(info.D.size() == 0 || info.D.size() == 4 || info.D.size() == 5 || info.D.size() == 8))
      fail(file, ": topic ", info.topic, ": ", info.D.size(),
           " distortion coefficients (plumb_bob has 5, rational_polynomial 8)");
    cv::initUndistortRectifyMap(K, info.D.empty() ? cv::Mat() : D, R, P, size, CV_32FC1, m1, m2);
  } else {
    fail(file, ": topic ", info.topic, ": distortion model '", info.distortion_model,
         "' is not supported (plumb_bob, rational_polynomial, equidistant)");
  }
  Remap map(m1, m2);
  require_coverage(map, int(info.width), int(info.height), cat(file, ": topic ", info.topic, "'s camera_info"));
  return map;
}


class RosbagDataset : public SequenceDataset {
 public:
  explicit RosbagDataset(const BagSpec& spec) : bag_(spec.file, spec.topics) {
    info_.kind = "rosbag";
    info_.path = spec.file;
    const auto& li = bag_.info();
    info_.camera = Camera(li.width, li.height, li.P[0], li.P[5], li.P[2], li.P[6]);
    left_ = rectification(li, spec.file);
    rgbd_ = !spec.topics.color.empty();
    if (const auto* ri = bag_.right_info()) {
      right_ = rectification(*ri, spec.file);
      const double fx = ri->P[0];
      if (ri->width != li.width || ri->height != li.height || std::abs(fx - li.P[0]) > 1e-6 * fx ||
          std::abs(ri->P[2] - li.P[2]) > 1e-6 * fx || std::abs(ri->P[6] - li.P[6]) > 1e-6 * fx)
        fail(spec.file, ": topic ", ri->topic, ": the right camera's size or projection P differs from ",
             li.topic, "'s; a rectified stereo pair shares one camera");
      info_.baseline = -ri->P[3] / fx;
      if (!(info_.baseline > 0))
        fail(spec.file, ": topic ", ri->topic, ": P gives a baseline of ", info_.baseline,
             " m; it must be positive (P[3] = -fx * baseline)");
      info_.has_right = true;
    }
    info_.has_depth = rgbd_;
    Image8 first = rosbag_io::image_of(bag_.image(0, 0));
    info_.color = first.channels() == 3;
    channels_ = first.channels();
    std::vector<double> stamps(bag_.frames());
    std::vector<std::optional<SE3>> gt;
    for (size_t i = 0; i < stamps.size(); ++i) stamps[i] = bag_.stamp(i);
    if (bag_.has_poses()) {
      gt.resize(stamps.size());
      for (size_t i = 0; i < stamps.size(); ++i)
        if (const auto& p = bag_.pose(i))
          gt[i] = SE3(Eigen::Quaterniond(p->q[3], p->q[0], p->q[1], p->q[2]).normalized(),
                      Eigen::Vector3d(p->t[0], p->t[1], p->t[2]));
    }
    info_.rate_hz = stamps.size() > 1 ? double(stamps.size() - 1) / (stamps.back() - stamps.front()) : 10;
    finish(stamps, gt);
    log::info("rosbag:", spec.file, ": ", stamps.size(), " frames from ",
              rgbd_ ? spec.topics.color : spec.topics.left, rgbd_ ? " (RGB-D)" : "",
              info_.has_right ? " (stereo)" : "",
              bag_.has_poses() ? ", poses of tf frame " + bag_.camera_frame() : "");
  }

  Frame frame(size_t i) const override {
    check_index(i);
    Frame f = frame_header(i, info_.path);
    f.source = info_.path.string() + " at " + std::to_string(timestamp(i)) + " s";
    f.left = load(0, i, left_);
    if (info_.has_right) f.right = load(1, i, right_);
    if (rgbd_) {
      ImageF d = rosbag_io::depth_of(bag_.image(i, 2));
      f.depth = left_.empty() ? std::move(d) : left_.apply_nearest(d);
    }
    return f;
  }

 private:
  Image8 load(int which, size_t i, const Remap& remap) const {
    Image8 img = rosbag_io::image_of(bag_.image(i, which));
    if (img.channels() != channels_)
      fail(info_.path.string(), " at ", timestamp(i), " s: image has ", img.channels(),
           " channels, the first had ", channels_);
    return remap.empty() ? img : remap.apply(img);
  }

  rosbag_io::BagReader bag_;
  Remap left_, right_;
  bool rgbd_ = false;
  int channels_ = 1;
};

#endif

}  // namespace

bool rosbag_supported() {
#ifdef CHUNGS_WITH_ROS
  return true;
#else
  return false;
#endif
}

std::unique_ptr<Dataset> open_rosbag(const std::string& spec) {
  BagSpec parsed = parse_spec(spec);
#ifdef CHUNGS_WITH_ROS
  return std::make_unique<RosbagDataset>(parsed);
#else
  fail("rosbag:", parsed.file, ": this build has no ROS support; install ROS 1 (scripts/setup.sh --ros) and ",
       "configure with -DCHUNGS_ROS=ON");
#endif
}

}  // namespace chungs::ds
