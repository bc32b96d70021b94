#include "chungs/render/sh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "chungs/gaussians/gaussian_block.hpp"

namespace chungs {
namespace {

std::array<double, 3> random_unit(std::mt19937& rng) {
  std::normal_distribution<double> N(0, 1);
  std::array<double, 3> d{N(rng), N(rng), N(rng)};
  const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (double& v : d) v /= n;
  return d;
}

// Addition theorem: for orthonormal real SH, the squares of one band sum to (2l + 1) / (4 pi) in
// every direction. A wrong constant or sign-independent term shows up here.
TEST(SphericalHarmonics, EachBandSatisfiesTheAdditionTheorem) {
  std::mt19937 rng(3);
  for (int t = 0; t < 50; ++t) {
    const auto d = random_unit(rng);
    double b[kShCoeffs];
    sh::basis(3, d[0], d[1], d[2], b);
    for (int l = 0; l <= 3; ++l) {
      double sum = 0;
      for (int k = l * l; k < (l + 1) * (l + 1); ++k) sum += b[k] * b[k];
      EXPECT_NEAR(sum, (2 * l + 1) / (4 * M_PI), 1e-12) << "band " << l;
    }
  }
}

TEST(SphericalHarmonics, BasisGradientMatchesFiniteDifferences) {
  std::mt19937 rng(4);
  for (int t = 0; t < 20; ++t) {
    const auto d = random_unit(rng);
    double g[3 * kShCoeffs];
    sh::basis_gradient(3, d[0], d[1], d[2], g);
    for (int a = 0; a < 3; ++a) {
      auto p = d, m = d;
      const double h = 1e-6;
      p[a] += h, m[a] -= h;
      double bp[kShCoeffs], bm[kShCoeffs];
      sh::basis(3, p[0], p[1], p[2], bp);
      sh::basis(3, m[0], m[1], m[2], bm);
      for (int k = 0; k < kShCoeffs; ++k) EXPECT_NEAR(g[3 * k + a], (bp[k] - bm[k]) / (2 * h), 1e-8) << k;
    }
  }
}

TEST(SphericalHarmonics, LowerDegreesLeaveHigherCoefficientsUntouched) {
  double b[kShCoeffs], full[kShCoeffs];
  for (double& v : b) v = -7;
  sh::basis(1, 0.6, 0.0, 0.8, b);
  sh::basis(3, 0.6, 0.0, 0.8, full);
  for (int k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(b[k], full[k]);
  for (int k = 4; k < kShCoeffs; ++k) EXPECT_EQ(b[k], -7);
}

}  // namespace
}  // namespace chungs
