// Random small scenes for the rasterizer tests: a camera with an off-centre principal point at a
// random pose, and overlapping Gaussians of random size, orientation, opacity and colour, some of
// them reaching past the image border.
#pragma once
#include <cmath>
#include <random>
#include <vector>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/render/gaussian_view.hpp"

namespace chungs::test {

template <typename T>
struct SceneArrays {
  std::vector<T> mean, log_scale, rotation, opacity, sh;
  size_t size() const { return opacity.size(); }
  GaussianArrays<T> view() const {
    return {mean.data(), log_scale.data(), rotation.data(), opacity.data(), sh.data(), size()};
  }
  template <typename U>
  SceneArrays<U> cast() const {
    auto c = [](const std::vector<T>& v) { return std::vector<U>(v.begin(), v.end()); };
    return {c(mean), c(log_scale), c(rotation), c(opacity), c(sh)};
  }
};

struct RandomScene {
  Camera camera;
  SE3 pose;  // camera-to-world
  SceneArrays<double> g;
};

// n Gaussians in front of a width x height camera. max_opacity keeps opacity * G below the 0.99
// alpha clamp when wanted (the clamp has a zero gradient, FD checks avoid it).
inline RandomScene make_random_scene(unsigned seed, int n, int width = 37, int height = 29,
                                     double max_logit = 1.5) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::normal_distribution<double> N(0, 1);
  RandomScene s;
  const double f = 30 + 10 * U(rng);
  s.camera = Camera(width, height, f, f * (0.9 + 0.2 * U(rng)), width * (0.35 + 0.3 * U(rng)),
                    height * (0.35 + 0.3 * U(rng)));
  Eigen::Quaterniond q(N(rng), N(rng), N(rng), N(rng));
  q.normalize();
  s.pose = SE3(q, Eigen::Vector3d(N(rng), N(rng), N(rng)));
  auto& g = s.g;
  g.mean.resize(3 * n), g.log_scale.resize(3 * n), g.rotation.resize(4 * n), g.opacity.resize(n);
  g.sh.resize(size_t(kShFloats) * n);
  for (int i = 0; i < n; ++i) {
    // Pixel position up to 5 px beyond the border, depth 1.5..4 m.
    const double u = -5 + (width + 10) * U(rng), v = -5 + (height + 10) * U(rng), z = 1.5 + 2.5 * U(rng);
    const Eigen::Vector3d pc((u - s.camera.cx) / s.camera.fx * z, (v - s.camera.cy) / s.camera.fy * z, z);
    const Eigen::Vector3d pw = s.pose * pc;
    for (int k = 0; k < 3; ++k) g.mean[3 * i + k] = pw[k];
    const double sigma_px = 1.5 + 3 * U(rng);
    for (int k = 0; k < 3; ++k) g.log_scale[3 * i + k] = std::log(sigma_px * z / f) + 0.3 * N(rng);
    const double qs = 0.5 + 1.5 * U(rng);  // not unit: the renderer normalises
    for (int k = 0; k < 4; ++k) g.rotation[4 * i + k] = qs * N(rng);
    g.opacity[i] = max_logit * (2 * U(rng) - 1);
    for (int k = 0; k < kShCoeffs; ++k)
      for (int c = 0; c < 3; ++c) g.sh[size_t(kShFloats) * i + 3 * k + c] = (k == 0 ? 0.6 : 0.2) * N(rng);
  }
  return s;
}

inline std::vector<uint32_t> iota_ids(size_t n) {
  std::vector<uint32_t> ids(n);
  for (size_t i = 0; i < n; ++i) ids[i] = uint32_t(i);
  return ids;
}

}  // namespace chungs::test
