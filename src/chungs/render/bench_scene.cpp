#include "chungs/render/bench_scene.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace chungs {

namespace {
Camera centred(int w, int h, double f) { return Camera(w, h, f, f, (w - 1) / 2.0, (h - 1) / 2.0); }
}  // namespace

Camera bench_camera_vga() { return centred(640, 480, 525); }
Camera bench_camera_kitti() { return centred(1241, 376, 718); }

GaussianParams make_bench_gaussians(size_t n, const Camera& cam, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::normal_distribution<double> N(0, 1);
  GaussianParams p;
  p.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const double z = 2 + 58 * std::pow(U(rng), 1.5);
    // Pixel position uniform over the image area (pixel centres at integers, so [-0.5, W - 0.5)).
    const double u = -0.5 + cam.width * U(rng), v = -0.5 + cam.height * U(rng);
    p.mean[3 * i] = float((u - cam.cx) / cam.fx * z);
    p.mean[3 * i + 1] = float((v - cam.cy) / cam.fy * z);
    p.mean[3 * i + 2] = float(z);
    const double grow = std::max(z / 10, 0.3);
    for (int k = 0; k < 3; ++k)
      p.log_scale[3 * i + k] = float(std::log(0.03) + 0.5 * N(rng) + std::log(grow));
    double q[4], norm = 0;
    for (double& c : q) {
      c = N(rng);
      norm += c * c;
    }
    norm = std::sqrt(norm);
    for (int k = 0; k < 4; ++k) p.rotation[4 * i + k] = float(q[k] / norm);
    p.opacity[i] = float(N(rng));  // the logit: opacity = sigmoid(N(0, 1))
    for (int k = 0; k < kShFloats; ++k) p.sh[size_t(kShFloats) * i + k] = float(0.2 * N(rng));
  }
  return p;
}

Image<float> make_bench_weights(int width, int height, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> U(0, 1);
  Image<float> w(width, height, 3);
  for (float& v : w.vec()) v = U(rng);
  return w;
}

}  // namespace chungs
