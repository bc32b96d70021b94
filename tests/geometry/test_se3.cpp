#include <gtest/gtest.h>

#include <random>

#include "chungs/common/error.hpp"
#include "chungs/geometry/se3.hpp"

using namespace chungs;

namespace {
SE3 random_se3(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return SE3(q.normalized(), Eigen::Vector3d(n(rng), n(rng), n(rng)) * 5);
}
}  // namespace

TEST(SE3, ComposeAndInverseMatchMatrices) {
  std::mt19937 rng(1);
  for (int i = 0; i < 100; ++i) {
    SE3 a = random_se3(rng), b = random_se3(rng);
    EXPECT_LT(((a * b).matrix() - a.matrix() * b.matrix()).norm(), 1e-12);
    EXPECT_LT(((a * a.inverse()).matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
    Eigen::Vector3d p(1.5, -2, 0.25);
    EXPECT_LT((a * p - (a.matrix() * p.homogeneous()).head<3>()).norm(), 1e-12);
  }
}

TEST(SE3, ExpInvertsLog) {
  std::mt19937 rng(2);
  for (int i = 0; i < 100; ++i) {
    SE3 a = random_se3(rng);
    SE3 b = SE3::exp(a.log());
    EXPECT_LT((a.matrix() - b.matrix()).norm(), 1e-9);
  }
}

TEST(SE3, FromMatrixRejectsNonRotation) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 0) = 2;
  try {
    SE3::from_matrix(m, "poses.txt:3");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("poses.txt:3"), std::string::npos);
  }
}

TEST(SE3, FromMatrixRejectsABottomRowOtherThan0001) {
  // A 3DMatch pose file whose last row read "0 0 5 1" was taken as a pose.
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(3, 2) = 5;
  try {
    SE3::from_matrix(m, "frame-000002.pose.txt");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "frame-000002.pose.txt: bottom row is (0, 0, 5, 1), expected (0, 0, 0, 1)"),
              std::string::npos)
        << e.what();
  }
  m(3, 2) = 0;
  EXPECT_NO_THROW(SE3::from_matrix(m, "frame-000002.pose.txt"));
}

TEST(Sim3, InverseAndApplyAreConsistent) {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    SE3 r = random_se3(rng);
    Sim3 s(0.3 + i * 0.05, r.q, r.t);
    Eigen::Vector3d p(0.1 * i, -1, 2);
    EXPECT_LT((s.inverse() * (s * p) - p).norm(), 1e-10);
    EXPECT_LT((s.matrix() * s.inverse().matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-10);
    Sim3 back = Sim3::from_matrix(s.matrix());
    EXPECT_NEAR(back.s, s.s, 1e-12);
    SE3 pose = random_se3(rng);
    SE3 moved = s.apply(pose);
    EXPECT_LT((moved.t - s * pose.t).norm(), 1e-10);
  }
  EXPECT_THROW(Sim3(-1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()), Error);
}
