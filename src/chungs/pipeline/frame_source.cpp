#include "chungs/pipeline/frame_source.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/geometry/trajectory.hpp"

namespace chungs {

std::vector<std::optional<SE3>> frame_poses(const Dataset& dataset, const std::string& source, double max_dt) {
  const size_t n = dataset.size();
  std::vector<std::optional<SE3>> out(n);
  if (source == "gt") {
    if (!dataset.info().has_gt) fail("poses 'gt': dataset ", dataset.info().path.string(), " has no ground truth");
    for (size_t i = 0; i < n; ++i) out[i] = dataset.gt_pose(i);
    return out;
  }
  const Trajectory t = read_trajectory(source, dataset.info().rate_hz > 0 ? dataset.info().rate_hz : 10.0);
  std::vector<double> stamps(n);
  for (size_t i = 0; i < n; ++i) stamps[i] = dataset.timestamp(i);
  // One pose per frame (a KITTI file, or a TUM file written for this dataset): pair by index.
  if (t.size() == n) {
    for (size_t i = 0; i < n; ++i) out[i] = t.poses[i];
    return out;
  }
  for (auto [a, b] : associate_stamps(stamps, t.stamps, max_dt)) out[a] = t.poses[b];
  return out;
}

Image8 scale_image(const Image8& img, double factor) {
  if (factor == 1.0) return img;
  const int w = std::max(1, int(std::lround(img.width() * factor))), h = std::max(1, int(std::lround(img.height() * factor)));
  const double inv = 1.0 / factor;
  const int k = int(std::lround(inv));
  if (std::abs(inv - k) < 1e-9) return box_downscale(img, k, w, h);
  return to_u8(resize_bilinear(to_float(img), w, h));
}

ImageF scale_depth(const ImageF& depth, int width, int height) {
  if (depth.width() == width && depth.height() == height) return depth;
  ImageF out(width, height, 1, 0.f);
  const double sx = double(depth.width()) / width, sy = double(depth.height()) / height;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      // Pixel centres map as in Camera::scaled: (x + 0.5) * s - 0.5.
      const int xx = std::clamp(int(std::lround((x + 0.5) * sx - 0.5)), 0, depth.width() - 1);
      const int yy = std::clamp(int(std::lround((y + 0.5) * sy - 0.5)), 0, depth.height() - 1);
      out(x, y) = depth(xx, yy);
    }
  return out;
}

double median_valid_depth(const ImageF& depth) {
  std::vector<float> v;
  v.reserve(depth.pixels());
  for (size_t i = 0; i < depth.pixels(); ++i) {
    const float d = depth.data()[i];
    if (d > 0 && std::isfinite(d)) v.push_back(d);
  }
  if (v.empty()) return 0;
  auto mid = v.begin() + long(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

MappingFrame load_mapping_frame(const Dataset& dataset, size_t i, double resolution, DepthMode mode,
                                StereoDepthConfig stereo, bool want_depth) {
  MappingFrame m;
  m.frame = dataset.frame(i);
  Frame& f = m.frame;
  if (resolution != 1.0) {
    f.left = scale_image(f.left, resolution);
    if (f.right) f.right = scale_image(*f.right, resolution);
    f.camera = f.camera.scaled(resolution);
    if (f.depth) f.depth = scale_depth(*f.depth, f.left.width(), f.left.height());
    stereo.num_disparities = std::max(16, int(std::ceil(stereo.num_disparities * resolution / 16.0)) * 16);
  }
  if (want_depth) {
    m.depth = frame_depth(f, mode, stereo);
    if (m.depth) m.median_depth = median_valid_depth(*m.depth);
  }
  return m;
}

}  // namespace chungs
