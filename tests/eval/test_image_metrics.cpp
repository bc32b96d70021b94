#include <gtest/gtest.h>

#include "image_fixtures.hpp"

#include <cmath>
#include <random>

#include "chungs/eval/image_metrics.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/image/image_io.hpp"
#include "test_support.hpp"

using namespace chungs;
using chungs::test::box_blur;

namespace {

ImageF random_image(int w, int h, int c, std::mt19937& rng, float lo = 0.f, float hi = 1.f) {
  std::uniform_real_distribution<float> u(lo, hi);
  ImageF img(w, h, c);
  for (float& v : img.vec()) v = u(rng);
  return img;
}

Image8 random_mask(int w, int h, std::mt19937& rng) {
  std::bernoulli_distribution keep(0.6);
  Image8 m(w, h, 1);
  for (auto& v : m.vec()) v = keep(rng) ? 1 : 0;
  m(0, 0) = 1;
  return m;
}

// Float64 reference: PSNR = 10 log10(1 / MSE) over kept pixels and all channels.
double reference_psnr(const ImageF& a, const ImageF& b, const Image8* mask) {
  double sq = 0;
  long n = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      if (mask && (*mask)(x, y) == 0) continue;
      for (int c = 0; c < a.channels(); ++c) {
        double d = double(a(x, y, c)) - double(b(x, y, c));
        sq += d * d, ++n;
      }
    }
  return 10.0 * std::log10(1.0 / (sq / double(n)));
}

}  // namespace

TEST(Psnr, MatchesFloat64ReferenceOnRandomImages) {
  std::mt19937 rng(17);
  const int sizes[][2] = {{7, 5}, {33, 17}, {64, 48}, {101, 37}};
  for (auto [w, h] : sizes)
    for (int ch : {1, 3})
      for (bool with_mask : {false, true}) {
        SCOPED_TRACE(::testing::Message() << w << "x" << h << "x" << ch << " mask " << with_mask);
        ImageF a = random_image(w, h, ch, rng), b = random_image(w, h, ch, rng);
        Image8 m = random_mask(w, h, rng);
        const Image8* mp = with_mask ? &m : nullptr;
        double ref = reference_psnr(a, b, mp);
        EXPECT_NEAR(psnr(a, b, mp), ref, 1e-5);
        EXPECT_GT(ref, 3.0);
        EXPECT_LT(ref, 12.0);
      }
}

TEST(Psnr, KnownPerturbationMatchesFormula) {
  std::mt19937 rng(18);
  std::bernoulli_distribution sign(0.5);
  for (double delta : {0.003, 0.02, 0.1}) {
    ImageF a = random_image(50, 40, 3, rng, 0.15f, 0.85f), b = a;
    for (float& v : b.vec()) v += float(sign(rng) ? delta : -delta);
    // Every pixel is off by exactly +-delta: MSE = delta^2, PSNR = -20 log10(delta).
    EXPECT_NEAR(psnr(a, b), -20.0 * std::log10(delta), 1e-4);
  }
  // Gaussian noise of sigma: PSNR ~ -20 log10(sigma) (statistically, 6000 samples).
  ImageF a = random_image(50, 40, 3, rng, 0.2f, 0.8f), b = a;
  std::normal_distribution<float> n(0.f, 0.01f);
  for (float& v : b.vec()) v += n(rng);
  EXPECT_NEAR(psnr(a, b), 40.0, 0.2);
}

TEST(Psnr, IdenticalImagesAreInfiniteAndWrittenAsNull) {
  std::mt19937 rng(19);
  ImageF a = random_image(20, 15, 3, rng);
  EXPECT_TRUE(std::isinf(psnr(a, a)));
  EXPECT_GT(psnr(a, a), 0.0);
  ImageMetrics m = compare_images(a, a);
  EXPECT_EQ(m.mse, 0.0);
  EXPECT_NEAR(m.ssim, 1.0, 1e-6);
  EXPECT_TRUE(to_json(m)["psnr"].is_null());
  EXPECT_NEAR(to_json(m)["ssim"].get<double>(), 1.0, 1e-6);
}

TEST(Psnr, EightBitImagesUse255Range) {
  std::mt19937 rng(20);
  std::uniform_int_distribution<int> u(0, 255);
  Image8 a(31, 23, 3), b(31, 23, 3);
  for (auto& v : a.vec()) v = uint8_t(u(rng));
  for (auto& v : b.vec()) v = uint8_t(u(rng));
  double sq = 0;
  for (size_t i = 0; i < a.size(); ++i) sq += double(a.vec()[i] - b.vec()[i]) * (a.vec()[i] - b.vec()[i]);
  const double expect = 10.0 * std::log10(255.0 * 255.0 / (sq / double(a.size())));
  EXPECT_NEAR(psnr(a, b), expect, 1e-6);
  EXPECT_NEAR(compare_images(a, b).psnr, expect, 1e-6);
}

TEST(Psnr, MaskRestrictsPixelsAndRejectsBadShapes) {
  std::mt19937 rng(21);
  ImageF a = random_image(30, 20, 3, rng), b = a;
  Image8 mask(30, 20, 1, 255);
  for (int y = 0; y < 20; ++y) mask(29, y) = 0;
  for (int y = 0; y < 20; ++y) b(29, y, 1) = 1.f - a(29, y, 1);  // only masked-out pixels differ
  EXPECT_TRUE(std::isinf(psnr(a, b, &mask)));
  EXPECT_FALSE(std::isinf(psnr(a, b)));
  EXPECT_EQ(compare_images(a, b, &mask).pixels, size_t(29 * 20));
  EXPECT_THROW(psnr(a, random_image(30, 21, 3, rng)), Error);
  EXPECT_THROW(psnr(a, random_image(30, 20, 1, rng)), Error);
  Image8 wrong(30, 19, 1, 1);
  EXPECT_THROW(psnr(a, b, &wrong), Error);
  Image8 none(30, 20, 1, 0);
  EXPECT_TRUE(std::isnan(psnr(a, b, &none)));
}

TEST(CompareImages, AgreesWithPsnrAndSsim) {
  std::mt19937 rng(22);
  ImageF a = random_image(45, 33, 3, rng), b = a;
  std::normal_distribution<float> n(0.f, 0.1f);
  for (float& v : b.vec()) v = std::clamp(v + n(rng), 0.f, 1.f);
  Image8 mask = random_mask(45, 33, rng);
  ImageMetrics m = compare_images(a, b, &mask);
  EXPECT_DOUBLE_EQ(m.psnr, psnr(a, b, &mask));
  EXPECT_DOUBLE_EQ(m.ssim, ssim(a, b, {}, &mask).mean);
  EXPECT_NEAR(m.psnr, psnr_from_mse(m.mse), 1e-12);
}

TEST(ImageMetricsRealData, JpegAgainstBlurredCopy) {
  CHUNGS_REQUIRE_DATA("replica_office0");
  auto file = test::shared_data("replica_office0") / "office0/results/frame000000.jpg";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << file << " absent";
  Image8 img8 = read_image8(file);
  ImageF img = to_float(img8);
  ImageMetrics light = compare_images(img, box_blur(img, 1));
  ImageMetrics heavy = compare_images(img, box_blur(img, 3));
  EXPECT_GT(light.psnr, 20.0);
  EXPECT_LT(light.psnr, 50.0);
  EXPECT_LT(heavy.psnr, light.psnr);
  EXPECT_LT(heavy.ssim, light.ssim);
  EXPECT_GT(light.ssim, 0.5);
  EXPECT_LT(light.ssim, 1.0);
  EXPECT_NEAR(light.psnr, reference_psnr(img, box_blur(img, 1), nullptr), 1e-5);
  EXPECT_TRUE(std::isinf(compare_images(img8, img8).psnr));
}
