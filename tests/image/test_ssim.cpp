#include <gtest/gtest.h>

#include "image_fixtures.hpp"

#include <cmath>
#include <random>

#include "chungs/image/image_io.hpp"
#include "chungs/image/ssim.hpp"
#include "test_support.hpp"

using namespace chungs;
using chungs::test::box_blur;

namespace {

ImageF random_image(int w, int h, int c, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.f, 1.f);
  ImageF img(w, h, c);
  for (float& v : img.vec()) v = u(rng);
  return img;
}

// b = a + noise, clipped: correlated like a render and its ground truth, so SSIM is well inside (0, 1).
ImageF noisy_copy(const ImageF& a, float sigma, std::mt19937& rng) {
  std::normal_distribution<float> n(0.f, sigma);
  ImageF b = a;
  for (float& v : b.vec()) v = std::clamp(v + n(rng), 0.f, 1.f);
  return b;
}

Image8 random_mask(int w, int h, double keep, std::mt19937& rng) {
  std::bernoulli_distribution bern(keep);
  Image8 m(w, h, 1);
  for (auto& v : m.vec()) v = bern(rng) ? 255 : 0;
  return m;
}

// Float64 reference: direct sums over the 2-D Gaussian window (no separability, no shifting),
// outside pixels are 0 (only reached in zero-pad mode). Returns the mean, fills the map.
double reference_ssim(const ImageF& a, const ImageF& b, SsimBorder border, const Image8* mask, double L,
                      std::vector<double>* map = nullptr) {
  const int win = 11, r = 5;
  const double sigma = 1.5;
  double w2[11][11], wsum = 0;
  for (int u = 0; u < win; ++u)
    for (int v = 0; v < win; ++v) wsum += w2[u][v] = std::exp(-((u - r) * (u - r) + (v - r) * (v - r)) / (2 * sigma * sigma));
  for (auto& row : w2)
    for (double& v : row) v /= wsum;
  const double c1 = (0.01 * L) * (0.01 * L), c2 = (0.03 * L) * (0.03 * L);
  const int off = border == SsimBorder::Valid ? r : 0;
  const int wo = border == SsimBorder::Valid ? a.width() - 2 * r : a.width();
  const int ho = border == SsimBorder::Valid ? a.height() - 2 * r : a.height();
  double sum = 0;
  long n = 0;
  if (map) map->assign(size_t(wo) * ho * a.channels(), 0.0);
  for (int i = 0; i < ho; ++i)
    for (int j = 0; j < wo; ++j)
      for (int c = 0; c < a.channels(); ++c) {
        const int cy = i + off, cx = j + off;
        double mx = 0, my = 0, mxx = 0, myy = 0, mxy = 0;
        for (int u = 0; u < win; ++u)
          for (int v = 0; v < win; ++v) {
            int y = cy + u - r, x = cx + v - r;
            if (y < 0 || x < 0 || y >= a.height() || x >= a.width()) continue;
            double p = a(x, y, c), q = b(x, y, c), w = w2[u][v];
            mx += w * p, my += w * q, mxx += w * p * p, myy += w * q * q, mxy += w * p * q;
          }
        double vx = mxx - mx * mx, vy = myy - my * my, cxy = mxy - mx * my;
        double s = ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
        if (map) (*map)[(size_t(i) * wo + j) * a.channels() + c] = s;
        if (mask && (*mask)(cx, cy) == 0) continue;
        sum += s, ++n;
      }
  return sum / n;
}

}  // namespace

TEST(Ssim, MatchesDirect2DReferenceOnRandomImages) {
  std::mt19937 rng(7);
  const int sizes[][2] = {{11, 11}, {23, 17}, {64, 48}, {37, 101}, {29, 157}};  // the last splits into bands
  for (auto border : {SsimBorder::Valid, SsimBorder::ZeroPad})
    for (auto [w, h] : sizes)
      for (int ch : {1, 3})
        for (bool with_mask : {false, true}) {
          SCOPED_TRACE(::testing::Message() << w << "x" << h << "x" << ch << " mask " << with_mask << " border "
                                            << int(border));
          ImageF a = random_image(w, h, ch, rng);
          ImageF b = noisy_copy(a, 0.15f, rng);
          Image8 m = random_mask(w, h, 0.6, rng);
          m(w / 2, h / 2) = 255;  // an 11x11 image has one valid window: keep it
          const Image8* mp = with_mask ? &m : nullptr;
          SsimOptions opt;
          opt.border = border;
          opt.want_map = true;
          SsimResult got = ssim(a, b, opt, mp);
          std::vector<double> ref_map;
          double ref = reference_ssim(a, b, border, mp, 1.0, &ref_map);
          EXPECT_NEAR(got.mean, ref, 1e-5);
          EXPECT_GT(ref, 0.05);
          EXPECT_LT(ref, 0.95);
          ASSERT_EQ(got.map.size(), ref_map.size());
          double worst = 0;
          for (size_t k = 0; k < ref_map.size(); ++k) worst = std::max(worst, std::abs(got.map.vec()[k] - ref_map[k]));
          EXPECT_LT(worst, 1e-5);
        }
}

TEST(Ssim, MatchesReferenceForIndependentImagesAndLargeRange) {
  std::mt19937 rng(11);
  ImageF a = random_image(41, 29, 3, rng), b = random_image(41, 29, 3, rng);
  EXPECT_NEAR(ssim(a, b).mean, reference_ssim(a, b, SsimBorder::Valid, nullptr, 1.0), 1e-5);
  // The same pair in [0, 255] with L = 255 has the same SSIM.
  ImageF a255 = a, b255 = b;
  for (float& v : a255.vec()) v *= 255.f;
  for (float& v : b255.vec()) v *= 255.f;
  SsimOptions opt;
  opt.data_range = 255.0;
  EXPECT_NEAR(ssim(a255, b255, opt).mean, reference_ssim(a, b, SsimBorder::Valid, nullptr, 1.0), 1e-5);
}

TEST(Ssim, IdenticalImagesScoreOne) {
  std::mt19937 rng(3);
  for (int ch : {1, 3}) {
    ImageF a = random_image(53, 31, ch, rng);
    EXPECT_NEAR(ssim(a, a).mean, 1.0, 1e-6);
    SsimOptions opt;
    opt.border = SsimBorder::ZeroPad;
    EXPECT_NEAR(ssim(a, a, opt).mean, 1.0, 1e-6);
  }
}

TEST(Ssim, MapHasValidOrSameSizeShape) {
  std::mt19937 rng(5);
  ImageF a = random_image(40, 30, 3, rng), b = noisy_copy(a, 0.1f, rng);
  SsimOptions opt;
  opt.want_map = true;
  SsimResult v = ssim(a, b, opt);
  EXPECT_EQ(v.map.width(), 30);
  EXPECT_EQ(v.map.height(), 20);
  EXPECT_EQ(v.map.channels(), 3);
  EXPECT_EQ(v.offset, 5);
  EXPECT_EQ(v.counted, 600u);
  opt.border = SsimBorder::ZeroPad;
  SsimResult z = ssim(a, b, opt);
  EXPECT_EQ(z.map.width(), 40);
  EXPECT_EQ(z.map.height(), 30);
  EXPECT_EQ(z.offset, 0);
  // Interior windows do not see the padding: both modes agree there.
  EXPECT_NEAR(z.map(12, 9, 1), v.map(7, 4, 1), 1e-6);
  // Without want_map no map is made.
  EXPECT_TRUE(ssim(a, b).map.empty());
}

TEST(Ssim, MaskCountsWindowsByCentrePixel) {
  std::mt19937 rng(9);
  ImageF a = random_image(30, 25, 3, rng), b = noisy_copy(a, 0.2f, rng);
  Image8 mask(30, 25, 1, 0);
  mask(17, 12) = 1;
  SsimOptions opt;
  opt.want_map = true;
  SsimResult r = ssim(a, b, opt, &mask);
  EXPECT_EQ(r.counted, 1u);
  double expect = (r.map(12, 7, 0) + r.map(12, 7, 1) + r.map(12, 7, 2)) / 3.0;
  EXPECT_NEAR(r.mean, expect, 1e-7);
  // A mask that keeps nothing gives NaN, not a crash or a made-up number.
  Image8 none(30, 25, 1, 0);
  EXPECT_TRUE(std::isnan(ssim(a, b, {}, &none).mean));
}

TEST(Ssim, RejectsBadInputs) {
  std::mt19937 rng(1);
  ImageF a = random_image(20, 20, 3, rng);
  EXPECT_THROW(ssim(a, random_image(20, 21, 3, rng)), Error);
  EXPECT_THROW(ssim(a, random_image(20, 20, 1, rng)), Error);
  ImageF small = random_image(10, 30, 1, rng);
  EXPECT_THROW(ssim(small, small), Error);
  SsimOptions zp;
  zp.border = SsimBorder::ZeroPad;
  EXPECT_NO_THROW(ssim(small, small, zp));
  SsimOptions even;
  even.window = 10;
  EXPECT_THROW(ssim(a, a, even), Error);
  Image8 bad_mask(20, 19, 1, 1);
  EXPECT_THROW(ssim(a, a, {}, &bad_mask), Error);
}

TEST(Ssim, RealJpegScoresDropWithBlur) {
  CHUNGS_REQUIRE_DATA("replica_office0");
  auto file = test::shared_data("replica_office0") / "office0/results/frame000000.jpg";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << file << " absent";
  ImageF img = to_float(read_image8(file));
  ImageF b1 = box_blur(img, 1), b3 = box_blur(img, 3);
  EXPECT_NEAR(ssim(img, img).mean, 1.0, 1e-6);
  double s1 = ssim(img, b1).mean, s3 = ssim(img, b3).mean;
  EXPECT_LT(s1, 1.0);
  EXPECT_GT(s1, 0.5);
  EXPECT_LT(s3, s1);
  EXPECT_GT(s3, 0.2);
  // Spot-check the separable float path on a real crop against the float64 2-D reference.
  ImageF crop(96, 64, 3), crop_b(96, 64, 3);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 96; ++x)
      for (int c = 0; c < 3; ++c) crop(x, y, c) = img(x + 200, y + 150, c), crop_b(x, y, c) = b1(x + 200, y + 150, c);
  EXPECT_NEAR(ssim(crop, crop_b).mean, reference_ssim(crop, crop_b, SsimBorder::Valid, nullptr, 1.0), 1e-5);
}
