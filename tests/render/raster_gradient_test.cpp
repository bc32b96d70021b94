// Finite-difference checks of the rasterizer's backward pass in float64, for every parameter of every
// Gaussian, with a loss that weighs every output (RGB, depth, inverse depth, alpha) by random weights.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "chungs/render/cpu/rasterizer.hpp"
#include "random_scene.hpp"

namespace chungs {
namespace {

template <typename T>
RenderGrads<T> random_weights(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1, 1);
  RenderGrads<T> g{Image<T>(w, h, 3), Image<T>(w, h, 1), Image<T>(w, h, 1), Image<T>(w, h, 1)};
  for (auto* img : {&g.rgb, &g.depth, &g.inv_depth, &g.alpha})
    for (auto& v : img->vec()) v = T(U(rng));
  return g;
}

template <typename T>
double weighted_sum(const RenderOutput<T>& o, const RenderGrads<T>& w) {
  double s = 0;
  for (size_t i = 0; i < o.rgb.size(); ++i) s += double(o.rgb.data()[i]) * double(w.rgb.data()[i]);
  for (size_t i = 0; i < o.depth.size(); ++i)
    s += double(o.depth.data()[i]) * w.depth.data()[i] +
         double(o.inv_depth.data()[i]) * w.inv_depth.data()[i] +
         double(o.alpha.data()[i]) * w.alpha.data()[i];
  return s;
}

struct GroupError {
  const char* name;
  double max_rel = 0;
  double max_grad = 0;
};

// Relative error |a - b| / max(|a|, |b|, floor); the floor keeps gradients that are zero up to
// rounding (a coefficient of a Gaussian that barely shows) from reading as large relative errors.
double rel_error(double a, double b, double floor) {
  return std::abs(a - b) / std::max({std::abs(a), std::abs(b), floor});
}

// Slots: the scene's Gaussians at shuffled positions among extra slots, plus one behind the camera
// and one far outside the view, so index mapping and culling are exercised.
struct GradScene {
  test::RandomScene scene;
  test::SceneArrays<double> arrays;
  std::vector<uint32_t> ids;
};

GradScene make_setup(unsigned seed, int n) {
  GradScene s;
  s.scene = test::make_random_scene(seed, n);
  const auto& g = s.scene.g;
  const int total = n + 4;
  auto& a = s.arrays;
  a.mean.assign(3 * total, 0.0), a.log_scale.assign(3 * total, -3.0), a.rotation.assign(4 * total, 0.5);
  a.opacity.assign(total, 0.0), a.sh.assign(size_t(kShFloats) * total, 0.1);
  std::vector<uint32_t> slots(total);
  for (int i = 0; i < total; ++i) slots[i] = uint32_t(i);
  std::shuffle(slots.begin(), slots.end(), std::mt19937(seed + 7));
  auto copy = [&](int src, uint32_t dst) {
    for (int k = 0; k < 3; ++k)
      a.mean[3 * dst + k] = g.mean[3 * src + k], a.log_scale[3 * dst + k] = g.log_scale[3 * src + k];
    for (int k = 0; k < 4; ++k) a.rotation[4 * dst + k] = g.rotation[4 * src + k];
    a.opacity[dst] = g.opacity[src];
    for (int k = 0; k < kShFloats; ++k) a.sh[size_t(kShFloats) * dst + k] = g.sh[size_t(kShFloats) * src + k];
  };
  for (int i = 0; i < n; ++i) {
    copy(i, slots[i]);
    s.ids.push_back(slots[i]);
  }
  // Behind the camera and far to the side (both culled); two more slots are never rendered.
  const Eigen::Vector3d behind = s.scene.pose * Eigen::Vector3d(0.1, 0.1, -2.0);
  const Eigen::Vector3d aside = s.scene.pose * Eigen::Vector3d(50.0, 0.0, 2.0);
  for (int k = 0; k < 3; ++k) a.mean[3 * slots[n] + k] = behind[k], a.mean[3 * slots[n + 1] + k] = aside[k];
  s.ids.push_back(slots[n]);
  s.ids.push_back(slots[n + 1]);
  return s;
}

TEST(RasterGradients, MatchFiniteDifferencesForEveryParameterInFloat64) {
  for (unsigned seed : {11u, 12u, 13u}) {
    GradScene s = make_setup(seed, 12);
    const RenderCamera<double> cam = make_render_camera<double>(s.scene.camera, s.scene.pose);
    CpuRasterizer<double> r(smooth_raster_config());
    const RenderGrads<double> w = random_weights<double>(cam.width, cam.height, seed);
    auto loss = [&]() { return weighted_sum(r.forward(s.arrays.view(), s.ids, cam), w); };
    loss();
    int visible = 0;
    for (uint8_t v : r.output().visible) visible += v;
    EXPECT_GE(visible, 8) << "seed " << seed;
    EXPECT_EQ(r.output().visible[12], 0);  // behind the camera
    EXPECT_EQ(r.output().visible[13], 0);  // outside the view
    GaussianGrads<double> grads;
    r.backward(w, grads);

    struct Group {
      const char* name;
      std::vector<double>* param;
      std::vector<double>* grad;
      int per;
      double step;
    } groups[] = {{"mean", &s.arrays.mean, &grads.mean, 3, 1e-6},
                  {"log_scale", &s.arrays.log_scale, &grads.log_scale, 3, 1e-6},
                  {"rotation", &s.arrays.rotation, &grads.rotation, 4, 1e-6},
                  {"opacity", &s.arrays.opacity, &grads.opacity, 1, 1e-6},
                  {"sh", &s.arrays.sh, &grads.sh, kShFloats, 1e-4}};
    for (const auto& gr : groups) {
      double max_rel = 0, max_abs_grad = 0;
      for (size_t j = 0; j < s.ids.size(); ++j)
        for (int k = 0; k < gr.per; ++k)
          max_abs_grad = std::max(max_abs_grad, std::abs((*gr.grad)[gr.per * j + k]));
      const double floor = 1e-6 * max_abs_grad;
      for (size_t j = 0; j < s.ids.size(); ++j)
        for (int k = 0; k < gr.per; ++k) {
          double& p = (*gr.param)[size_t(gr.per) * s.ids[j] + k];
          const double p0 = p;
          p = p0 + gr.step;
          const double lp = loss();
          p = p0 - gr.step;
          const double lm = loss();
          p = p0;
          const double fd = (lp - lm) / (2 * gr.step);
          const double an = (*gr.grad)[size_t(gr.per) * j + k];
          const double e = rel_error(an, fd, floor);
          EXPECT_LT(e, 1e-4) << gr.name << " of Gaussian " << j << " [" << k << "] seed " << seed
                             << ": analytic " << an << " finite difference " << fd;
          max_rel = std::max(max_rel, e);
        }
      RecordProperty(std::string(gr.name) + "_seed" + std::to_string(seed), std::to_string(max_rel));
      std::printf("seed %u %-9s max relative error %.2e (largest |grad| %.3g)\n", seed, gr.name, max_rel,
                  max_abs_grad);
    }
  }
}

}  // namespace
}  // namespace chungs
