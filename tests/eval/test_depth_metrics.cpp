// Depth quality (AbsRel, delta < 1.25): hand-checked values, invalid pixels left out, pooling over
// images, and the errors on mismatched or unreadable input.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/eval/depth_metrics.hpp"
#include "chungs/image/image_io.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

Image16 encode(const ImageF& depth, double scale) {
  Image16 out(depth.width(), depth.height(), 1);
  for (size_t i = 0; i < depth.size(); ++i) out.vec()[i] = uint16_t(std::lround(depth.vec()[i] * scale));
  return out;
}

ImageF image(int w, int h, std::initializer_list<float> v) {
  ImageF img(w, h, 1);
  std::copy(v.begin(), v.end(), img.vec().begin());
  return img;
}

TEST(DepthMetrics, HandCheckedValuesSkipInvalidPixels) {
  const float nan = std::nanf("");
  // The last four pixels are invalid in one image or the other: 0, NaN, negative, inf.
  const ImageF gt = image(4, 2, {2, 4, 5, 10, 0, 3, 7, INFINITY});
  const ImageF est = image(4, 2, {2.2f, 3, 5, 13, 6, 0, nan, 4});
  const DepthMetrics m = compare_depth(gt, est);
  EXPECT_EQ(m.pixels, 4u);
  EXPECT_EQ(m.gt_valid, 6u);
  // |0.2|/2 + 1/4 + 0 + 3/10 = 0.65 over 4; ratios 1.1, 1.33, 1, 1.3: two inside 1.25.
  EXPECT_NEAR(m.abs_rel, 0.1625, 1e-6);
  EXPECT_DOUBLE_EQ(m.delta1, 0.5);
  EXPECT_NEAR(m.rmse, std::sqrt((0.04 + 1 + 0 + 9) / 4), 1e-6);
  // A mask keeps the first column only.
  Image8 mask(4, 2, 1, 0);
  mask(0, 0) = 9;
  const DepthMetrics k = compare_depth(gt, est, &mask);
  EXPECT_EQ(k.pixels, 1u);
  EXPECT_NEAR(k.abs_rel, 0.1, 1e-6);
}

TEST(DepthMetrics, RandomDepthsScaledByAKnownFactor) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0.5f, 60.0f);
  ImageF gt(37, 23, 1);
  for (float& v : gt.vec()) v = U(rng);
  for (const double k : {0.9, 1.1, 1.2, 1.3, 0.7}) {
    ImageF est = gt;
    for (float& v : est.vec()) v = float(v * k);
    const DepthMetrics m = compare_depth(gt, est);
    EXPECT_NEAR(m.abs_rel, std::abs(k - 1), 1e-5) << k;
    EXPECT_DOUBLE_EQ(m.delta1, std::max(k, 1 / k) < 1.25 ? 1.0 : 0.0) << k;
    EXPECT_EQ(m.pixels, gt.pixels());
  }
  // Pooled over two images: pixel-weighted, not image-weighted.
  ImageF half(37, 23, 1, 0.0f), est(37, 23, 1, 0.0f);
  for (size_t i = 0; i < 100; ++i) half.vec()[i] = gt.vec()[i], est.vec()[i] = float(gt.vec()[i] * 1.5);
  DepthErrorSum sum;
  sum.add(gt, gt);
  sum.add(half, est);
  const DepthMetrics p = sum.result();
  EXPECT_EQ(p.pixels, gt.pixels() + 100);
  EXPECT_NEAR(p.abs_rel, 0.5 * 100 / double(gt.pixels() + 100), 1e-6);
  EXPECT_NEAR(p.delta1, double(gt.pixels()) / double(gt.pixels() + 100), 1e-12);
}

TEST(DepthMetrics, NoCommonPixelGivesNaNNotZero) {
  const DepthMetrics m = compare_depth(image(2, 1, {3, 0}), image(2, 1, {0, 4}));
  EXPECT_EQ(m.pixels, 0u);
  EXPECT_TRUE(std::isnan(m.abs_rel));
  EXPECT_TRUE(std::isnan(m.delta1));
}

TEST(DepthMetrics, MismatchedImagesAreErrorsNamingThem) {
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([] { compare_depth(ImageF(4, 3), ImageF(3, 4)); }).find("4x3"), std::string::npos);
  EXPECT_NE(message([] { compare_depth(ImageF(4, 3, 3), ImageF(4, 3)); }).find("1 channel"), std::string::npos);
  DepthErrorSum s;
  EXPECT_NE(message([&] { s.add(ImageF(2, 2), ImageF(2, 3), nullptr, "frame 7"); }).find("frame 7"),
            std::string::npos);
}

TEST(DepthMetrics, PngPairsAreReadWithTheirScalesAndBadFilesNamed) {
  test::TempDir dir;
  const auto gt_dir = dir.path() / "gt", est_dir = dir.path() / "est";
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> U(1.0f, 12.0f);
  ImageF gt(20, 10, 1);
  for (float& v : gt.vec()) v = U(rng);
  ImageF est = gt;
  for (float& v : est.vec()) v *= 1.1f;
  write_png(gt_dir / "000001.png", encode(gt, 5000));
  write_png(est_dir / "000001.png", encode(est, 1000));
  const DepthSetResult r = evaluate_depth_pairs(match_image_pairs(gt_dir, est_dir), 5000, 1000);
  ASSERT_EQ(r.images.size(), 1u);
  EXPECT_NEAR(r.pooled.abs_rel, 0.1, 2e-3);  // 1 mm steps on the estimate
  EXPECT_EQ(r.pooled.pixels, 200u);
  // Read with the wrong scale the figure is far off: the scale is applied.
  EXPECT_GT(evaluate_depth_pairs(match_image_pairs(gt_dir, est_dir), 5000, 5000).pooled.abs_rel, 0.7);
  EXPECT_THROW(read_depth_png(gt_dir / "000001.png", 0), Error);
  write_png(dir.path() / "rgb.png", Image8(4, 4, 3, 9));
  try {
    read_depth_png(dir.path() / "rgb.png", 5000);
    ADD_FAILURE() << "an 8-bit RGB file was read as depth";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rgb.png"), std::string::npos) << e.what();
  }
  write_png(est_dir / "000001.png", encode(ImageF(21, 10, 1, 2.0f), 1000));
  EXPECT_THROW(evaluate_depth_pairs(match_image_pairs(gt_dir, est_dir), 5000, 1000), Error);
}

}  // namespace
}  // namespace chungs
