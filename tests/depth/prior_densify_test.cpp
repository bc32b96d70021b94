// Densifying sparse depth samples into a prior: a depth step along an image edge stays sharp (and it
// is the image-guided filter that keeps it so), a plane is interpolated, confidence falls away from
// the samples, and bad samples are refused by index.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/depth/plane_sweep.hpp"
#include "chungs/depth/prior_densify.hpp"
#include "sweep_scene.hpp"

namespace chungs {
namespace {

// Left of x = 60 a dark textured surface at 2 m, right of it a bright one at 8 m.
struct Step {
  Image8 image{120, 80, 1};
  std::vector<DepthSample> samples;
  float inv(int x) const { return x < 60 ? 0.5f : 0.125f; }
  Step() {
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> n(0, 40);
    for (int y = 0; y < 80; ++y)
      for (int x = 0; x < 120; ++x) image(x, y) = uint8_t((x < 60 ? 40 : 170) + n(rng));
    std::uniform_real_distribution<float> X(0, 119), Y(0, 79);
    for (int i = 0; i < 150; ++i) {  // about 1.5 % of the pixels
      const float x = X(rng), y = Y(rng);
      samples.push_back({x, y, 1.0f / inv(int(std::lround(x))), 1.0f + float(i % 3)});
    }
  }
  // Share of the pixels within 4 columns of the edge whose inverse depth is within 10 % of the truth.
  double right_at_edge(const DensePrior& p) const {
    size_t n = 0, ok = 0;
    for (int y = 0; y < 80; ++y)
      for (int x = 56; x < 64; ++x, ++n) ok += std::abs(p.inv_depth(x, y) - inv(x)) < 0.1f * inv(x);
    return double(ok) / double(n);
  }
};

TEST(PriorDensify, ADepthStepAlongAnImageEdgeStaysSharp) {
  const Step s;
  const DensePrior p = densify_prior(s.image, s.samples);
  EXPECT_GT(s.right_at_edge(p), 0.97);
  // Normalized convolution alone (no guided passes) makes a ramp of the step.
  DensifyConfig plain;
  plain.iterations = 0;
  const DensePrior q = densify_prior(s.image, s.samples, plain);
  EXPECT_LT(s.right_at_edge(q), 0.85) << "the unguided fill kept the edge: the test no longer shows the filter";
  std::printf("near the edge within 10 %%: guided %.3f, unguided %.3f\n", s.right_at_edge(p), s.right_at_edge(q));
  for (size_t i = 0; i < p.inv_depth.pixels(); ++i) {
    ASSERT_GT(p.inv_depth.vec()[i], 0.0f) << "pixel " << i << " left empty";
    ASSERT_TRUE(p.confidence.vec()[i] > 0.0f && p.confidence.vec()[i] <= 1.0f) << i;
  }
}

TEST(PriorDensify, InterpolatesAPlaneAndTrustsItLessFarFromSamples) {
  // A slanted plane: its inverse depth is affine in the pixel. No samples in a 36 px hole.
  Image8 image(140, 100, 1);
  std::mt19937 rng(2);
  std::uniform_int_distribution<int> n(90, 140);
  for (auto& v : image.vec()) v = uint8_t(n(rng));
  auto inv = [](double x, double y) { return 0.2 + 0.001 * x + 0.0015 * y; };
  std::vector<DepthSample> samples;
  std::uniform_real_distribution<float> X(0, 139), Y(0, 99);
  while (samples.size() < 200) {
    const float x = X(rng), y = Y(rng);
    if (x > 52 && x < 88 && y > 32 && y < 68) continue;
    samples.push_back({x, y, float(1.0 / inv(std::lround(x), std::lround(y))), 1.0f});
  }
  const DensePrior p = densify_prior(image, samples);
  // The fill is of order zero (weighted means), so a slope through the hole is flattened a little.
  double worst = 0, mean = 0;
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 140; ++x) {
      const double e = std::abs(p.inv_depth(x, y) - inv(x, y)) / inv(x, y);
      worst = std::max(worst, e), mean += e / (140 * 100);
    }
  EXPECT_LT(mean, 0.02);
  EXPECT_LT(worst, 0.12);
  std::printf("plane: mean error %.4f, worst %.4f\n", mean, worst);
  // The hole's centre is filled but trusted less than the surroundings near samples.
  double near = 0;
  size_t count = 0;
  for (const DepthSample& s : samples) near += p.confidence(int(std::lround(s.x)), int(std::lround(s.y))), ++count;
  near /= double(count);
  EXPECT_GT(p.inv_depth(70, 50), 0.0f);
  EXPECT_LT(p.confidence(70, 50), 0.5 * near) << "centre " << p.confidence(70, 50) << ", at samples " << near;
}

TEST(PriorDensify, NoSamplesNoPriorAndBadSamplesNamed) {
  const Image8 image(30, 20, 3, 100);
  const DensePrior none = densify_prior(image, {{-5, 3, 2, 1}, {31, 3, 2, 1}});  // off the image: unseen
  for (float v : none.inv_depth.vec()) ASSERT_EQ(v, 0.0f);
  for (float v : none.confidence.vec()) ASSERT_EQ(v, 0.0f);
  auto message = [&](std::vector<DepthSample> s) {
    try {
      densify_prior(image, s);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({{1, 1, 2, 1}, {2, 2, -3, 1}}).find("sample 1 has depth -3"), std::string::npos);
  EXPECT_NE(message({{1, 1, 2, 0}}).find("sample 0 has weight 0"), std::string::npos);
  EXPECT_NE(message({{NAN, 1, 2, 1}}).find("sample 0"), std::string::npos);
  DensifyConfig bad;
  bad.radius = 0;
  EXPECT_THROW(densify_prior(image, {}, bad), Error);
}

TEST(PriorDensify, SparseNoisyPointsThenThePlaneSweepRecoverTheScene) {
  // The monocular path end to end: map points with 15 % depth noise on 1 % of the pixels, densified,
  // then refined by the sweep against two neighbours.
  const test::SweepScene scene = test::wall_box_scene();
  Image8 ref, a, b;
  ImageF gt, unused;
  scene.render(SE3(), ref, gt, 1.5, 1);
  const SE3 pa = test::translated(0.35, 0, 0), pb = test::translated(-0.2, 0.25, 0.1);
  scene.render(pa, a, unused, 1.5, 2);
  scene.render(pb, b, unused, 1.5, 3);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.15f);
  std::vector<DepthSample> samples;
  for (int i = 0; i < 190; ++i) {
    const int x = int(rng() % 160), y = int(rng() % 120);
    if (gt(x, y) > 0) samples.push_back({float(x), float(y), gt(x, y) * std::max(0.5f, 1 + noise(rng)), 1.0f});
  }
  const DensePrior prior = densify_prior(ref, samples);
  PlaneSweepInput in;
  in.camera = scene.camera;
  in.reference = {&ref, SE3()};
  in.neighbours = {{&a, pa}, {&b, pb}};
  in.prior_inv_depth = &prior.inv_depth;
  in.prior_confidence = &prior.confidence;
  std::vector<SweepPixel> px;
  for (int y = 8; y < 112; y += 3)
    for (int x = 8; x < 152; x += 3) px.push_back({x, y});
  PlaneSweepConfig c;
  c.near = 1.0, c.far = 20.0;
  c.max_rel_per_px = 0.5;  // short baselines (see plane_sweep_test.cpp)
  const std::vector<SweepSample> got = plane_sweep_at(in, px, c);
  double prior_err = 0, err = 0;
  size_t n = 0;
  for (size_t i = 0; i < px.size(); ++i) {
    const float g = gt(px[i].x, px[i].y), d = got[i].depth;
    if (d <= 0 || g <= 0) continue;
    ++n;
    err += std::abs(d - g) / g;
    prior_err += std::abs(1.0f / prior.inv_depth(px[i].x, px[i].y) - g) / g;
  }
  ASSERT_GT(n, px.size() / 2);
  std::printf("%zu of %zu pixels: prior AbsRel %.4f, refined %.4f\n", n, px.size(), prior_err / double(n),
              err / double(n));
  EXPECT_LT(err / double(n), 0.03);
  EXPECT_LT(err, 0.3 * prior_err) << "prior AbsRel " << prior_err / double(n) << ", refined " << err / double(n);
}

}  // namespace
}  // namespace chungs
