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
  std::vector<Eigen::Vector3d> line{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  EXPECT_THROW(umeyama_align(line, line, true), Error);
}
