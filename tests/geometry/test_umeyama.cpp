#include <gtest/gtest.h>

#include <random>

#include "chungs/common/error.hpp"
#include "chungs/geometry/umeyama.hpp"

using namespace chungs;

TEST(Umeyama, RecoversRandomSim3AndSE3) {
  std::mt19937 rng(6);
  std::normal_distribution<double> n(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Sim3 truth(0.2 + 3 * std::abs(n(rng)), Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(),
               Eigen::Vector3d(n(rng), n(rng), n(rng)) * 10);
    std::vector<Eigen::Vector3d> src, dst, dst_rigid;
    for (int i = 0; i < 50; ++i) {
      Eigen::Vector3d p(n(rng), n(rng), n(rng));
      src.push_back(p);
      dst.push_back(truth * p);
      dst_rigid.push_back(truth.q * p + truth.t);
    }
    Sim3 est = umeyama_align(src, dst, true);
    EXPECT_NEAR(est.s, truth.s, 1e-9);
    EXPECT_LT((est.matrix() - truth.matrix()).norm(), 1e-8);
    Sim3 rigid = umeyama_align(src, dst_rigid, false);
    EXPECT_DOUBLE_EQ(rigid.s, 1.0);
    EXPECT_LT((rigid.t - truth.t).norm(), 1e-8);
  }
}

TEST(Umeyama, RejectsDegenerateInput) {
  std::vector<Eigen::Vector3d> a{{0, 0, 0}, {1, 0, 0}}, b = a;
  EXPECT_THROW(umeyama_align(a, b, true), Error);
  std::vector<Eigen::Vector3d> here{{1, 2, 3}, {1, 2, 3}, {1, 2, 3}}, line{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  EXPECT_THROW(umeyama_align(here, line, true), Error);
  EXPECT_THROW(umeyama_align(line, here, false), Error);
  // Varying, but not together: each point of one set pairs with a zero-mean spread of the other.
  std::vector<Eigen::Vector3d> cross{{1, 0, 0}, {-1, 0, 0}, {1, 0, 0}, {-1, 0, 0}},
      other{{0, 1, 0}, {0, 1, 0}, {0, -1, 0}, {0, -1, 0}};
  EXPECT_THROW(umeyama_align(cross, other, true), Error);
}

namespace {
// The mean squared error of dst ~ s R src + t with s and t optimal for the given R (closed form).
double best_mse_for(const Eigen::Matrix3d& R, const std::vector<Eigen::Vector3d>& src,
                    const std::vector<Eigen::Vector3d>& dst, bool with_scale) {
  const size_t n = src.size();
  Eigen::Vector3d ms = Eigen::Vector3d::Zero(), md = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) ms += src[i] / double(n), md += dst[i] / double(n);
  double num = 0, den = 0;
  for (size_t i = 0; i < n; ++i) num += (dst[i] - md).dot(R * (src[i] - ms)), den += (src[i] - ms).squaredNorm();
  const double s = with_scale ? num / den : 1.0;
  double e = 0;
  for (size_t i = 0; i < n; ++i) e += (dst[i] - md - s * R * (src[i] - ms)).squaredNorm();
  return e / double(n);
}

double mse(const Sim3& a, const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  double e = 0;
  for (size_t i = 0; i < src.size(); ++i) e += (dst[i] - a * src[i]).squaredNorm();
  return e / double(src.size());
}
}  // namespace

// A straight drive: its positions lie on a line, which used to be refused ("rotation is undetermined"),
// so `eval ate` had no answer for a straight excerpt. The free rotation moves no point on the line.
TEST(Umeyama, AlignsCollinearPointsOptimally) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d dir = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
    const Sim3 truth(0.5 + std::abs(n(rng)), Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(),
                     Eigen::Vector3d(n(rng), n(rng), n(rng)) * 5);
    std::vector<Eigen::Vector3d> line, moved, noisy;
    for (int i = 0; i < 40; ++i) {
      const Eigen::Vector3d p = dir * (0.7 * i + n(rng)) + Eigen::Vector3d(1, -2, 3);
      line.push_back(p);
      moved.push_back(truth * p);
      noisy.push_back(truth * p + 0.3 * Eigen::Vector3d(n(rng), n(rng), n(rng)));
    }
    // Exactly: a line onto the same line moved by a Sim3.
    const Sim3 exact = umeyama_align(line, moved, true);
    EXPECT_NEAR(exact.s, truth.s, 1e-9);
    EXPECT_LT(mse(exact, line, moved), 1e-16);
    // A line onto noisy points (and those onto the line), with and without scale: no rotation does better.
    for (bool with_scale : {true, false})
      for (int flip = 0; flip < 2; ++flip) {
        const auto& src = flip ? noisy : line;
        const auto& dst = flip ? line : noisy;
        const Sim3 a = umeyama_align(src, dst, with_scale);
        const double got = mse(a, src, dst);
        EXPECT_NEAR(got, best_mse_for(a.q.toRotationMatrix(), src, dst, with_scale), 1e-9 * (1 + got));
        for (int k = 0; k < 300; ++k) {
          const Eigen::Matrix3d R =
              Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
          EXPECT_LE(got, best_mse_for(R, src, dst, with_scale) + 1e-9 * (1 + got)) << trial << " " << k;
        }
      }
  }
}
