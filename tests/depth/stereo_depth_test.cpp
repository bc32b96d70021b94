// Stereo depth on synthetic rectified pairs with known disparity.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "chungs/depth/depth_source.hpp"
#include "chungs/depth/stereo_depth.hpp"

namespace chungs {
namespace {

// Random blobs texture (smooth enough to match, rich enough to be unique).
Image8 texture(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> U(0, 255);
  Image8 coarse(w / 2 + 2, h / 2 + 2, 1);
  for (auto& v : coarse.vec()) v = uint8_t(U(rng));
  Image8 out(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      out(x, y) = uint8_t((coarse(x / 2, y / 2) * 3 + coarse(x / 2 + 1, y / 2 + 1)) / 4);
  return out;
}

// Right image of a scene whose disparity is d_left(x, y) at the left pixel: right(x - d) = left(x).
Image8 shift(const Image8& left, int d_near, int d_far, int split_x) {
  Image8 right(left.width(), left.height(), 1, 0);
  for (int y = 0; y < left.height(); ++y)
    for (int xr = 0; xr < left.width(); ++xr) {
      // Near region on the left image's columns < split_x.
      const int xl_near = xr + d_near, xl_far = xr + d_far;
      int xl = xl_far;
      if (xl_near < split_x) xl = xl_near;
      right(xr, y) = xl < left.width() ? left(xl, y) : 0;
    }
  return right;
}

TEST(StereoDepth, RecoversMetricDepthOfAConstantDisparity) {
  const Image8 l = texture(160, 96, 3);
  const Image8 r = shift(l, 12, 12, 0);
  const double fx = 100, b = 0.5;
  StereoDepthConfig c;
  c.num_disparities = 32;
  const StereoDepth s = stereo_depth(l, r, fx, b, c);
  std::vector<float> d;
  for (int y = 0; y < 96; ++y)
    for (int x = 40; x < 160; ++x)
      if (s.depth(x, y) > 0) d.push_back(s.depth(x, y));
  ASSERT_GT(d.size(), 0.6 * 120 * 96);
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  EXPECT_NEAR(d[d.size() / 2], fx * b / 12, 0.05);
  EXPECT_GE(s.valid, 1u);
}

TEST(StereoDepth, ColumnsWithinTheSearchRangeOfTheLeftEdgeGetDepthToo) {
  // A search range as wide as most of the image (a small image at the default range): only the
  // columns whose match lies outside the right image (x < disparity) may go without depth.
  const Image8 l = texture(96, 48, 11);
  const Image8 r = shift(l, 10, 10, 0);
  const double fx = 80, b = 0.5;
  StereoDepthConfig c;
  c.num_disparities = 64;
  const StereoDepth s = stereo_depth(l, r, fx, b, c);
  size_t valid = 0, right_depth = 0;
  for (int y = 4; y < 44; ++y)
    for (int x = 16; x < 64; ++x) {  // all within the 64-pixel range of the left edge
      if (s.depth(x, y) <= 0) continue;
      ++valid;
      if (std::abs(s.depth(x, y) - fx * b / 10) < 0.2) ++right_depth;
    }
  EXPECT_GT(valid, size_t(0.6 * 40 * 48));
  EXPECT_GT(right_depth, size_t(0.95 * double(valid)));
}

TEST(StereoDepth, SeparatesTwoDepthsAndRejectsOcclusions) {
  const Image8 l = texture(200, 80, 5);
  const Image8 r = shift(l, 20, 8, 100);
  const double fx = 200, b = 0.3;
  StereoDepthConfig c;
  c.num_disparities = 32;
  const StereoDepth s = stereo_depth(l, r, fx, b, c);
  auto median_in = [&](int x0, int x1) {
    std::vector<float> d;
    for (int y = 10; y < 70; ++y)
      for (int x = x0; x < x1; ++x)
        if (s.depth(x, y) > 0) d.push_back(s.depth(x, y));
    EXPECT_FALSE(d.empty());
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    return d.empty() ? 0.f : d[d.size() / 2];
  };
  EXPECT_NEAR(median_in(40, 90), fx * b / 20, 0.1);
  EXPECT_NEAR(median_in(120, 190), fx * b / 8, 0.2);
  // Wrong depths (neither plane) must be rare: the left-right check removes mismatches.
  size_t wrong = 0, valid = 0;
  for (int y = 0; y < 80; ++y)
    for (int x = 32; x < 200; ++x)
      if (s.depth(x, y) > 0) {
        ++valid;
        const float z = s.depth(x, y);
        if (std::abs(z - 3.0f) > 0.3f && std::abs(z - 7.5f) > 0.8f) ++wrong;
      }
  EXPECT_LT(double(wrong), 0.05 * double(valid));
}

TEST(StereoDepth, RejectsMismatchedImages) {
  EXPECT_THROW(stereo_depth(Image8(10, 10), Image8(12, 10), 100, 0.5), Error);
  EXPECT_THROW(stereo_depth(Image8(64, 64), Image8(64, 64), 100, 0), Error);
}

TEST(DepthSource, PicksSensorThenStereoThenMultiview) {
  EXPECT_EQ(resolve_depth_mode(DepthMode::Auto, true, true), DepthMode::Sensor);
  EXPECT_EQ(resolve_depth_mode(DepthMode::Auto, false, true), DepthMode::Stereo);
  EXPECT_EQ(resolve_depth_mode(DepthMode::Auto, false, false), DepthMode::Multiview);
  EXPECT_EQ(parse_depth_mode("multiview"), DepthMode::Multiview);
  EXPECT_THROW(parse_depth_mode("lidar"), Error);
  Frame f;
  f.left = Image8(8, 8);
  EXPECT_THROW(frame_depth(f, DepthMode::Stereo), Error);
  EXPECT_FALSE(frame_depth(f, DepthMode::None).has_value());
  EXPECT_FALSE(frame_depth(f, DepthMode::Multiview).has_value());  // the run sweeps it against its neighbours
}

}  // namespace
}  // namespace chungs
