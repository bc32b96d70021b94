#include <gtest/gtest.h>

#include <random>

#include "chungs/eval/lpips.hpp"
#include "lpips_fixtures.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {

// A smooth image with structure (gradients and a disc), on which noise is a perceptual change.
ImageF smooth_image(int w, int h) {
  ImageF img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float dx = x - 0.4f * w, dy = y - 0.5f * h;
      const bool disc = dx * dx + dy * dy < 0.08f * w * h;
      img(x, y, 0) = float(x) / w;
      img(x, y, 1) = disc ? 0.9f : float(y) / h;
      img(x, y, 2) = 0.5f + 0.4f * std::sin(0.3f * x) * std::cos(0.2f * y);
    }
  return img;
}

}  // namespace

TEST(Lpips, MatchesFloat64DefinitionOnRandomWeights) {
  std::mt19937 rng(21);
  const LpipsWeights w = test::random_lpips_weights(22);
  const Lpips metric(w);
  const ImageF a = test::random_image(52, 44, 3, rng), b = test::random_image(52, 44, 3, rng);
  const ImageF s = smooth_image(52, 44), sn = test::with_noise(s, 0.1f, rng);
  for (auto [x, y] : {std::pair{&a, &b}, {&s, &sn}, {&a, &s}}) {
    const double want = test::lpips64(w, *x, *y);
    EXPECT_GT(want, 0.0);
    EXPECT_NEAR(metric.distance(*x, *y), want, 1e-5 * std::max(1.0, want));
  }
}

TEST(Lpips, IdenticalImagesAreExactlyZero) {
  std::mt19937 rng(23);
  const Lpips metric(test::random_lpips_weights(24));
  const ImageF a = test::random_image(70, 50, 3, rng);
  const ImageF copy = a;
  EXPECT_EQ(metric.distance(a, copy), 0.0);
  EXPECT_EQ(metric.distance(smooth_image(40, 33), smooth_image(40, 33)), 0.0);
}

TEST(Lpips, IsSymmetric) {
  std::mt19937 rng(25);
  const Lpips metric(test::random_lpips_weights(26));
  const ImageF a = smooth_image(80, 48), b = test::with_noise(a, 0.05f, rng);
  EXPECT_EQ(metric.distance(a, b), metric.distance(b, a));
  const auto la = metric.layer_distances(a, b);
  double sum = 0;
  for (double v : la) {
    EXPECT_GE(v, 0.0);
    sum += v;
  }
  EXPECT_NEAR(sum, metric.distance(a, b), 1e-12);
}

TEST(Lpips, GrowsWithNoise) {
  std::mt19937 rng(27);
  const Lpips metric(test::random_lpips_weights(28));
  const ImageF a = smooth_image(96, 64);
  double last = 0;
  for (float sigma : {0.01f, 0.04f, 0.12f, 0.3f}) {
    const double d = metric.distance(a, test::with_noise(a, sigma, rng));
    EXPECT_GT(d, last) << "sigma " << sigma;
    last = d;
  }
}

TEST(Lpips, GrayIsScoredAsReplicatedRgb) {
  std::mt19937 rng(29);
  const Lpips metric(test::random_lpips_weights(30));
  const ImageF g = test::random_image(40, 36, 1, rng), h = test::random_image(40, 36, 1, rng);
  EXPECT_EQ(metric.distance(g, h), metric.distance(to_rgb(g), to_rgb(h)));
}

TEST(Lpips, RefusesMismatchedOrBadInputs) {
  const Lpips metric(test::random_lpips_weights(31));
  EXPECT_THROW(metric.distance(ImageF(40, 40, 3), ImageF(41, 40, 3)), Error);
  EXPECT_THROW(metric.distance(ImageF(20, 40, 3), ImageF(20, 40, 3)), Error);
  LpipsWeights w = test::random_lpips_weights(32);
  w.lin[0][0] = -1.f;
  EXPECT_THROW(Lpips{w}, Error);
  w = test::random_lpips_weights(32);
  w.conv[2].bias.pop_back();
  EXPECT_THROW(Lpips{w}, Error);
}

TEST(Lpips, SettingWithoutWeightsSaysWhyAndHasNoMetric) {
  const LpipsSetting s = lpips_setting("", "--lpips-weights");
  EXPECT_FALSE(s.metric);
  EXPECT_NE(s.unavailable.find("no --lpips-weights"), std::string::npos) << s.unavailable;
  test::TempDir dir;
  write_lpips_weights(dir / "w.dclpips", test::random_lpips_weights(33));
  const LpipsSetting t = lpips_setting(dir / "w.dclpips", "--lpips-weights");
  ASSERT_TRUE(t.metric);
  EXPECT_TRUE(t.unavailable.empty());
  EXPECT_THROW(lpips_setting(dir / "absent.dclpips", "--lpips-weights"), Error);
}
