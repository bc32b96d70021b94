// The losses against finite differences in float64 and against direct definitions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/optim/loss.hpp"
#include "chungs/optim/loss_depth.hpp"
#include "chungs/optim/loss_l1.hpp"
#include "chungs/optim/loss_ssim.hpp"

namespace chungs {
namespace {

Image<double> random_image(int w, int h, int c, unsigned seed, double lo = 0.05, double hi = 0.95) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(lo, hi);
  Image<double> img(w, h, c);
  for (double& v : img.vec()) v = U(rng);
  return img;
}

double rel_error(double a, double b, double floor) {
  return std::abs(a - b) / std::max({std::abs(a), std::abs(b), floor});
}

// Central differences of f over every element of x against the analytic gradient g.
double max_fd_error(Image<double>& x, const Image<double>& g, const std::function<double()>& f, double h) {
  double gmax = 0, worst = 0;
  size_t at = 0;
  double fd_at = 0;
  for (double v : g.vec()) gmax = std::max(gmax, std::abs(v));
  for (size_t i = 0; i < x.size(); ++i) {
    const double x0 = x.data()[i];
    x.data()[i] = x0 + h;
    const double fp = f();
    x.data()[i] = x0 - h;
    const double fm = f();
    x.data()[i] = x0;
    const double e = rel_error(g.data()[i], (fp - fm) / (2 * h), 1e-6 * gmax);
    if (e > worst) worst = e, at = i, fd_at = (fp - fm) / (2 * h);
  }
  std::printf("  %zu elements, max relative error %.2e (element %zu: analytic %.9g, central difference %.9g)\n",
              x.size(), worst, at, g.data()[at], fd_at);
  return worst;
}

TEST(Losses, L1GradientMatchesFiniteDifferences) {
  Image<double> pred = random_image(9, 7, 3, 1), target = random_image(9, 7, 3, 2);
  Image<double> g(9, 7, 3);
  const double v = l1_loss(pred, target, &g, 0.7);
  double direct = 0;
  for (size_t i = 0; i < pred.size(); ++i) direct += std::abs(pred.data()[i] - target.data()[i]);
  EXPECT_NEAR(v, direct / pred.size(), 1e-15);
  EXPECT_LT(max_fd_error(
                pred, g, [&] { return 0.7 * l1_loss(pred, target); }, 1e-7),
            1e-4);
}

// Direct SSIM: the 11x11 window summed explicitly at each pixel, zero outside the image.
double direct_ssim(const Image<double>& x, const Image<double>& y) {
  double w1[11], s = 0;
  for (int i = 0; i < 11; ++i) s += w1[i] = std::exp(-0.5 * (i - 5) * (i - 5) / 2.25);
  double total = 0;
  for (int c = 0; c < x.channels(); ++c)
    for (int v = 0; v < x.height(); ++v)
      for (int u = 0; u < x.width(); ++u) {
        double mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
        for (int dv = -5; dv <= 5; ++dv)
          for (int du = -5; du <= 5; ++du) {
            const int uu = u + du, vv = v + dv;
            if (uu < 0 || vv < 0 || uu >= x.width() || vv >= x.height()) continue;
            const double w = w1[du + 5] * w1[dv + 5] / (s * s), a = x(uu, vv, c), b = y(uu, vv, c);
            mx += w * a, my += w * b, xx += w * a * a, yy += w * b * b, xy += w * a * b;
          }
        const double c1 = 1e-4, c2 = 9e-4;
        total += (2 * mx * my + c1) * (2 * (xy - mx * my) + c2) /
                 ((mx * mx + my * my + c1) * ((xx - mx * mx) + (yy - my * my) + c2));
      }
  return total / x.size();
}

TEST(Losses, SsimMatchesDirectWindowSumAndIsOneForIdenticalImages) {
  // Widths where no pixel, one pixel and many pixels have the whole window inside the image.
  for (const int w : {7, 11, 23}) {
    const Image<double> a = random_image(w, 17, 3, 3), b = random_image(w, 17, 3, 4);
    EXPECT_NEAR(ssim_loss_term(a, b), direct_ssim(a, b), 1e-12) << w << " wide";
  }
  const Image<double> a = random_image(23, 17, 3, 3), b = random_image(23, 17, 3, 4);
  EXPECT_NEAR(ssim_loss_term(a, a), 1.0, 1e-12);
  Image<double> g(23, 17, 3);
  ssim_loss_term(a, a, &g);
  for (double v : g.vec()) EXPECT_NEAR(v, 0.0, 1e-12);  // a maximum: zero gradient
}

TEST(Losses, SsimGradientMatchesFiniteDifferences) {
  Image<double> pred = random_image(19, 14, 3, 5), target = random_image(19, 14, 3, 6);
  // Make the images related, as a render and its target are, so SSIM is far from 0.
  for (size_t i = 0; i < pred.size(); ++i) pred.data()[i] = 0.6 * target.data()[i] + 0.4 * pred.data()[i];
  Image<double> g(19, 14, 3);
  ssim_loss_term(pred, target, &g, -0.2);
  EXPECT_LT(max_fd_error(
                pred, g, [&] { return -0.2 * ssim_loss_term(pred, target); }, 1e-6),
            1e-4);
}

TEST(Losses, InverseDepthL1IgnoresInvalidAndMaskedPixels) {
  Image<double> pred = random_image(11, 9, 1, 7, 0.1, 1.0), target = random_image(11, 9, 1, 8, 0.1, 1.0);
  Image<uint8_t> mask(11, 9, 1, 1);
  target(2, 3) = 0;                                         // no measurement
  target(4, 4) = std::numeric_limits<double>::quiet_NaN();  // no measurement
  target(7, 1) = -1;                                        // invalid
  mask(5, 5) = 0;                                           // masked out
  Image<double> g(11, 9, 1);
  size_t valid = 0;
  const double v = inverse_depth_l1(pred, target, &mask, &g, 1.5, &valid);
  EXPECT_EQ(valid, 11u * 9u - 4u);
  double direct = 0;
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 11; ++x)
      if (target(x, y) > 0 && mask(x, y)) direct += std::abs(pred(x, y) - target(x, y));
  EXPECT_NEAR(v, direct / valid, 1e-15);
  for (auto [x, y] : {std::pair{2, 3}, {4, 4}, {7, 1}, {5, 5}}) EXPECT_EQ(g(x, y), 0.0);
  EXPECT_LT(max_fd_error(
                pred, g, [&] { return 1.5 * inverse_depth_l1(pred, target, &mask); }, 1e-7),
            1e-4);
  Image<double> none(11, 9, 1, 0.0);
  EXPECT_EQ(inverse_depth_l1(pred, none), 0.0);
  EXPECT_THROW(inverse_depth_l1(pred, Image<double>(10, 9, 1)), Error);
}

TEST(Losses, InverseDepthOfMarksMissingDepthInvalid) {
  Image<float> d(3, 1, 1);
  d(0, 0) = 2.0f, d(1, 0) = 0.0f, d(2, 0) = std::numeric_limits<float>::infinity();
  const Image<float> inv = inverse_depth_of(d);
  EXPECT_FLOAT_EQ(inv(0, 0), 0.5f);
  EXPECT_EQ(inv(1, 0), 0.0f);
  EXPECT_EQ(inv(2, 0), 0.0f);
}

TEST(Losses, MappingLossCombinesTermsAndItsGradientMatchesFiniteDifferences) {
  for (double lambda_depth : {0.0, 0.1, 1.0}) {
    RenderOutput<double> r;
    r.rgb = random_image(16, 13, 3, 9);
    r.inv_depth = random_image(16, 13, 1, 10, 0.05, 0.8);
    const Image<double> target = random_image(16, 13, 3, 11);
    Image<double> target_inv = random_image(16, 13, 1, 12, 0.05, 0.8);
    target_inv(3, 3) = 0;
    const LossConfig cfg{0.2, lambda_depth};
    RenderGrads<double> g;
    const LossTerms t = mapping_loss(cfg, r, target, &target_inv, nullptr, &g);
    EXPECT_NEAR(t.total, 0.8 * t.l1 + 0.2 * (1 - t.ssim) + lambda_depth * t.depth, 1e-15);
    EXPECT_NEAR(t.l1, l1_loss(r.rgb, target), 1e-15);
    auto f = [&] { return mapping_loss(cfg, r, target, &target_inv, nullptr, nullptr).total; };
    EXPECT_LT(max_fd_error(r.rgb, g.rgb, f, 1e-7), 1e-4);
    if (lambda_depth > 0) {
      EXPECT_EQ(t.depth_pixels, 16u * 13u - 1u);
      EXPECT_LT(max_fd_error(r.inv_depth, g.inv_depth, f, 1e-7), 1e-4);
    } else {
      EXPECT_TRUE(g.inv_depth.empty());
    }
  }
}

TEST(Losses, PixelMaskZeroesGradientsOutsideItAndKeepsThemInside) {
  RenderOutput<double> r;
  r.rgb = random_image(23, 17, 3, 21);
  r.inv_depth = random_image(23, 17, 1, 22, 0.05, 0.8);
  const Image<double> target = random_image(23, 17, 3, 23);
  const Image<double> target_inv = random_image(23, 17, 1, 24, 0.05, 0.8);
  Image<uint8_t> mask(23, 17, 1);
  std::mt19937 rng(25);
  for (auto& m : mask.vec()) m = rng() % 3 != 0;
  const LossConfig cfg{0.2, 0.5};
  RenderGrads<double> all, masked;
  const LossTerms ta = mapping_loss(cfg, r, target, &target_inv, nullptr, &all);
  const LossTerms tm = mapping_loss(cfg, r, target, &target_inv, nullptr, &masked, &mask);
  EXPECT_EQ(ta.total, tm.total);  // the terms stay those of the whole image
  size_t outside = 0;
  for (size_t i = 0; i < mask.pixels(); ++i) {
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(masked.rgb.data()[3 * i + c], mask.data()[i] ? all.rgb.data()[3 * i + c] : 0.0);
    EXPECT_EQ(masked.inv_depth.data()[i], mask.data()[i] ? all.inv_depth.data()[i] : 0.0);
    if (!mask.data()[i] && all.rgb.data()[3 * i] != 0) ++outside;
  }
  EXPECT_GT(outside, 50u);  // the mask removed real gradient
  const Image<uint8_t> wrong(22, 17, 1, 1);
  EXPECT_THROW(mapping_loss(cfg, r, target, &target_inv, nullptr, &masked, &wrong), Error);
}

}  // namespace
}  // namespace chungs
