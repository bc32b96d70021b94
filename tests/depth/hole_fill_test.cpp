// The membrane fill of pixels without depth: planes come back as planes, known pixels stay.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <cstdio>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/depth/hole_fill.hpp"

namespace chungs {
namespace {

// Inverse depth of a slanted plane: affine in the pixel.
float plane(int x, int y) { return 0.25f + 0.0011f * float(x) - 0.0007f * float(y); }

TEST(HoleFill, APlaneKnownOnlyAtScatteredPixelsIsFilledAsThatPlane) {
  const int w = 157, h = 93;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> U(0, 1);
  ImageF inv(w, h, 1, 0.f);
  size_t known = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      // Sparse samples and one large empty block (a textureless wall), away from the border.
      if (U(rng) < 0.03f && !(x > 40 && x < 120 && y > 20 && y < 75)) inv(x, y) = plane(x, y), ++known;
  ASSERT_GT(known, 200u);
  const ImageF out = fill_holes_membrane(inv);
  double worst = 0, border_worst = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (inv(x, y) > 0) {
        EXPECT_EQ(out(x, y), inv(x, y)) << "a known pixel changed at " << x << "," << y;
        continue;
      }
      const double e = std::abs(double(out(x, y)) - plane(x, y)) / plane(x, y);
      if (x > 40 && x < 120 && y > 20 && y < 75) worst = std::max(worst, e);
      else border_worst = std::max(border_worst, e);
    }
  std::printf("largest relative error: %.4f in the block, %.4f elsewhere\n", worst, border_worst);
  EXPECT_LT(worst, 0.02) << "largest relative error of a filled pixel in the empty block";
  // The border is mirrored (no depth beyond the image), so there the fill flattens a little.
  EXPECT_LT(border_worst, 0.06) << "largest relative error of a filled pixel elsewhere";
}

TEST(HoleFill, TwoSurfacesAreBlendedWithinTheirRange) {
  // Left half at 1/2 m, right half at 1/5 m, the middle third empty: the fill stays between them and
  // rises monotonically across the gap.
  const int w = 90, h = 40;
  ImageF inv(w, h, 1, 0.f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x < 30) inv(x, y) = 0.5f;
      if (x >= 60) inv(x, y) = 0.2f;
    }
  const ImageF out = fill_holes_membrane(inv);
  for (int x = 30; x < 60; ++x) {
    EXPECT_LE(out(x, 20), 0.5f + 1e-5f);
    EXPECT_GE(out(x, 20), 0.2f - 1e-5f);
    if (x > 30) EXPECT_LE(out(x, 20), out(x - 1, 20) + 1e-5f) << x;
  }
  EXPECT_NEAR(out(45, 20), 0.35f, 0.02f);
}

TEST(HoleFill, NothingKnownStaysEmptyAndBadInputIsRefused) {
  const ImageF none(20, 10, 1, 0.f);
  const ImageF out = fill_holes_membrane(none);
  for (float v : out.vec()) EXPECT_EQ(v, 0.f);
  ImageF odd(8, 8, 1, 0.f);
  odd(3, 3) = std::numeric_limits<float>::quiet_NaN();  // not a depth: treated as unknown
  odd(5, 5) = 0.4f;
  const ImageF filled = fill_holes_membrane(odd);
  EXPECT_NEAR(filled(3, 3), 0.4f, 1e-6f);
  EXPECT_THROW(fill_holes_membrane(ImageF(4, 4, 3, 0.f)), Error);
}

}  // namespace
}  // namespace chungs
