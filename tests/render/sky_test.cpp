// The sky behind the Gaussians: its gradients against finite differences on random textures, cameras
// and renders; the chain into the Gaussians through the rasterizer's alpha gradient (float64); the
// taps at the poles and the azimuth seam; Adam on texels.
#include "chungs/render/sky.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/render/cpu/rasterizer.hpp"
#include "random_scene.hpp"

namespace chungs {
namespace {

SkyTexture random_sky(std::mt19937& rng, int w = 16, int h = 8) {
  std::uniform_real_distribution<double> U(0, 1);
  std::normal_distribution<double> N(0, 1);
  const Eigen::Matrix3d R =
      Eigen::Quaterniond(N(rng), N(rng), N(rng), N(rng)).normalized().toRotationMatrix();
  double r[9];
  for (int i = 0; i < 9; ++i) r[i] = R(i / 3, i % 3);
  SkyConfig cfg;
  cfg.width = w;
  cfg.height = h;
  SkyTexture s = make_sky(cfg, r);
  for (float& v : s.rgb) v = float(U(rng));
  return s;
}

ImageF random_image(std::mt19937& rng, int w, int h, int c, double lo, double hi) {
  std::uniform_real_distribution<double> U(lo, hi);
  ImageF im(w, h, c);
  for (float& v : im.vec()) v = float(U(rng));
  return im;
}

// L = sum of weights * composed rgb.
double composed_loss(const SkyTexture& sky, const RenderCamera<float>& cam, const ImageF& rgb,
                     const ImageF& alpha, const ImageF& weights) {
  ImageF sky_px, out = rgb;
  sky_colours(sky, cam, sky_px);
  compose_sky(sky_px, alpha, out);
  double l = 0;
  for (size_t i = 0; i < out.vec().size(); ++i) l += double(weights.vec()[i]) * out.vec()[i];
  return l;
}

TEST(Sky, TexelAndAlphaGradientsMatchFiniteDifferences) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    std::mt19937 rng(seed);
    const test::RandomScene scene = test::make_random_scene(seed, 1, 23, 17);
    const RenderCamera<float> cam = make_render_camera<float>(scene.camera, scene.pose);
    SkyTexture sky = random_sky(rng);
    const ImageF rgb = random_image(rng, cam.width, cam.height, 3, 0, 1);
    ImageF alpha = random_image(rng, cam.width, cam.height, 1, 0, 1);
    const ImageF weights = random_image(rng, cam.width, cam.height, 3, -1, 1);
    ImageF sky_px, grad_alpha;
    sky_colours(sky, cam, sky_px);
    std::vector<float> grad(3 * sky.texels(), 0.f);
    sky_backward(sky, cam, sky_px, alpha, weights, grad_alpha, grad);
    // Texels: the loss is linear in them, so central differences are exact up to rounding.
    size_t seen = 0;
    for (size_t j = seed % 2; j < grad.size(); j += 2) {
      const float keep = sky.rgb[j];
      sky.rgb[j] = keep + 0.25f;
      const double lp = composed_loss(sky, cam, rgb, alpha, weights);
      sky.rgb[j] = keep - 0.25f;
      const double lm = composed_loss(sky, cam, rgb, alpha, weights);
      sky.rgb[j] = keep;
      const double fd = (lp - lm) / 0.5;
      EXPECT_NEAR(grad[j], fd, 1e-3 * (1 + std::abs(fd))) << "seed " << seed << " value " << j;
      seen += std::abs(fd) > 1e-3;
    }
    EXPECT_GT(seen, 4u) << "the camera must see part of the texture";
    for (int p = 0; p < cam.width * cam.height; p += 7) {
      const int u = p % cam.width, v = p / cam.width;
      const float keep = alpha(u, v);
      alpha(u, v) = keep + 0.01f;
      const double lp = composed_loss(sky, cam, rgb, alpha, weights);
      alpha(u, v) = keep - 0.01f;
      const double lm = composed_loss(sky, cam, rgb, alpha, weights);
      alpha(u, v) = keep;
      const double fd = (lp - lm) / 0.02;
      EXPECT_NEAR(grad_alpha(u, v), fd, 1e-3 * (1 + std::abs(fd)))
          << "seed " << seed << " pixel " << u << "," << v;
    }
  }
}

// The sky's alpha gradient, chained through the rasterizer's backward, is the gradient of the
// composed image with respect to the Gaussians (opacity and position, float64 rasterizer).
TEST(Sky, GradientReachesTheGaussiansThroughAlpha) {
  const test::RandomScene scene = test::make_random_scene(5, 12, 29, 23, 1.0);
  std::mt19937 rng(5);
  const SkyTexture sky = random_sky(rng);
  const RenderCamera<double> cam = make_render_camera<double>(scene.camera, scene.pose);
  const RenderCamera<float> camf = make_render_camera<float>(scene.camera, scene.pose);
  ImageF sky_px;
  sky_colours(sky, camf, sky_px);
  const ImageF wf = random_image(rng, cam.width, cam.height, 3, -1, 1);
  const std::vector<uint32_t> ids = test::iota_ids(scene.g.size());
  auto loss = [&](const test::SceneArrays<double>& g) {
    CpuRasterizer<double> r(smooth_raster_config());
    const RenderOutput<double>& out = r.forward(g.view(), ids, cam);
    double l = 0;
    for (int v = 0; v < cam.height; ++v)
      for (int u = 0; u < cam.width; ++u)
        for (int c = 0; c < 3; ++c)
          l += double(wf(u, v, c)) * (out.rgb(u, v, c) + (1 - out.alpha(u, v)) * double(sky_px(u, v, c)));
    return l;
  };
  CpuRasterizer<double> r(smooth_raster_config());
  const RenderOutput<double> out = r.forward(scene.g.view(), ids, cam);
  ImageF alpha_f(cam.width, cam.height, 1), grad_alpha_f;
  for (size_t i = 0; i < alpha_f.vec().size(); ++i) alpha_f.vec()[i] = float(out.alpha.vec()[i]);
  std::vector<float> texel_grad(3 * sky.texels(), 0.f);
  sky_backward(sky, camf, sky_px, alpha_f, wf, grad_alpha_f, texel_grad);
  RenderGrads<double> dl;
  dl.rgb = Image<double>(cam.width, cam.height, 3);
  dl.alpha = Image<double>(cam.width, cam.height, 1);
  for (size_t i = 0; i < wf.vec().size(); ++i) dl.rgb.vec()[i] = wf.vec()[i];
  for (size_t i = 0; i < grad_alpha_f.vec().size(); ++i) dl.alpha.vec()[i] = grad_alpha_f.vec()[i];
  GaussianGrads<double> grads;
  r.backward(dl, grads);
  for (size_t i = 0; i < scene.g.size(); ++i) {
    test::SceneArrays<double> g = scene.g;
    const double h = 1e-5;
    g.opacity[i] += h;
    const double lp = loss(g);
    g.opacity[i] -= 2 * h;
    const double lm = loss(g);
    const double fd = (lp - lm) / (2 * h);
    EXPECT_NEAR(grads.opacity[i], fd, 1e-4 * (1 + std::abs(fd))) << "opacity of Gaussian " << i;
    g = scene.g;
    g.mean[3 * i] += h;
    const double mp = loss(g);
    g.mean[3 * i] -= 2 * h;
    const double mm = loss(g);
    const double fdm = (mp - mm) / (2 * h);
    EXPECT_NEAR(grads.mean[3 * i], fdm, 1e-4 * (1 + std::abs(fdm))) << "mean x of Gaussian " << i;
  }
}

TEST(Sky, TapsStayInTheTextureAtPolesAndSeam) {
  std::mt19937 rng(9);
  const SkyTexture sky = random_sky(rng, 32, 16);
  const float* a = sky.axes;
  // Straight up, straight down, and just either side of the azimuth seam (-east, +-north).
  const float dirs[][3] = {{a[6], a[7], a[8]},
                           {-a[6], -a[7], -a[8]},
                           {-a[0] + 1e-4f * a[3], -a[1] + 1e-4f * a[4], -a[2] + 1e-4f * a[5]},
                           {-a[0] - 1e-4f * a[3], -a[1] - 1e-4f * a[4], -a[2] - 1e-4f * a[5]}};
  for (const auto& d : dirs) {
    const SkyTap t = sky_tap(sky.axes, sky.width, sky.height, d[0], d[1], d[2]);
    float sum = 0;
    for (int k = 0; k < 4; ++k) {
      EXPECT_LT(t.index[k], sky.texels());
      EXPECT_GE(t.weight[k], -1e-6f);
      sum += t.weight[k];
    }
    EXPECT_NEAR(sum, 1.f, 1e-5f);
  }
  // Either side of the seam reads the same two columns (the first and the last).
  const SkyTap l = sky_tap(sky.axes, sky.width, sky.height, dirs[2][0], dirs[2][1], dirs[2][2]);
  const SkyTap r = sky_tap(sky.axes, sky.width, sky.height, dirs[3][0], dirs[3][1], dirs[3][2]);
  EXPECT_EQ(l.index[0] % uint32_t(sky.width), uint32_t(sky.width - 1));
  EXPECT_EQ(r.index[0] % uint32_t(sky.width), uint32_t(sky.width - 1));
  EXPECT_EQ(l.index[1] % uint32_t(sky.width), 0u);
}

TEST(Sky, AdamMovesOnlySeenTexelsAndFitsATarget) {
  std::mt19937 rng(3);
  SkyTexture sky = random_sky(rng, 8, 4);
  const SkyTexture before = sky;
  std::vector<float> grad(3 * sky.texels(), 0.f);
  grad[3] = 0.5f, grad[4] = -2.f, grad[5] = 1e-3f;  // texel 1 only
  sky_adam_step(sky, grad, 0.05);
  EXPECT_EQ(sky.updates[1], 1u);
  for (size_t i = 0; i < sky.texels(); ++i)
    if (i != 1) {
      EXPECT_EQ(sky.updates[i], 0u);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(sky.rgb[3 * i + c], before.rgb[3 * i + c]);
    }
  // The first bias-corrected step is lr against the sign of the gradient (unless clamped to [0, 1]).
  for (int c = 0; c < 3; ++c) {
    const float want = std::clamp(before.rgb[3 + c] - 0.05f * (grad[3 + c] > 0 ? 1.f : -1.f), 0.f, 1.f);
    EXPECT_NEAR(sky.rgb[3 + c], want, 1e-5f);
  }
  // Minimising 0.5 |rgb - target|^2 reaches the target.
  std::vector<float> target(sky.rgb.size());
  std::uniform_real_distribution<float> U(0.1f, 0.9f);
  for (float& v : target) v = U(rng);
  for (int it = 0; it < 600; ++it) {
    for (size_t j = 0; j < grad.size(); ++j) grad[j] = sky.rgb[j] - target[j];
    sky_adam_step(sky, grad, 0.01);
  }
  for (size_t j = 0; j < grad.size(); ++j) EXPECT_NEAR(sky.rgb[j], target[j], 0.02f);
}

TEST(Sky, SettingsAndTexturesOutOfRangeAreRefused) {
  SkyConfig c;
  c.width = 2;
  EXPECT_THROW(c.validate(), Error);
  c = SkyConfig{};
  c.lr = std::nan("");
  EXPECT_THROW(c.validate(), Error);
  std::mt19937 rng(1);
  SkyTexture s = random_sky(rng);
  s.rgb[5] = std::nanf("");
  EXPECT_THROW(s.check(), Error);
  s = random_sky(rng);
  s.m2.pop_back();
  EXPECT_THROW(s.check(), Error);
}

}  // namespace
}  // namespace chungs
