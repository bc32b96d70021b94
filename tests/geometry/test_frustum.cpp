#include <gtest/gtest.h>

#include <random>

#include "chungs/geometry/frustum.hpp"

using namespace chungs;

TEST(Frustum, ContainsExactlyThePointsThatProjectIntoTheImage) {
  Camera cam(1241, 376, 718, 718, 607, 185);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  std::uniform_real_distribution<double> u(-80, 80);
  int inside = 0;
  for (int k = 0; k < 20; ++k) {
    SE3 pose(Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(), Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.1);
    Frustum f = Frustum::from_view_projection(view_projection_matrix(cam, pose, 0.1, 100));
    for (int i = 0; i < 2000; ++i) {
      Eigen::Vector3d pw(u(rng), u(rng), u(rng));
      Eigen::Vector3d pc = pose.inverse() * pw;
      bool expect = pc.z() >= 0.1 && pc.z() <= 100 && cam.in_image(cam.project(pc));
      // Points within 1e-6 of a border may go either way.
      Eigen::Vector2d px = cam.project(pc);
      double margin = std::min({std::abs(px.x() + 0.5), std::abs(px.x() - cam.width + 0.5), std::abs(px.y() + 0.5),
                                std::abs(px.y() - cam.height + 0.5)});
      if (pc.z() > 0 && margin < 1e-6) continue;
      EXPECT_EQ(f.contains(pw), expect) << pw.transpose();
      inside += expect;
    }
  }
  EXPECT_GT(inside, 100);
}

TEST(Frustum, BoxTestsAreConservative) {
  Camera cam(640, 480, 525, 525, 319.5, 239.5);
  Frustum f = Frustum::from_view_projection(view_projection_matrix(cam, SE3(), 0.1, 100));
  EXPECT_TRUE(f.intersects_box({-1, -1, 5}, {1, 1, 7}));
  EXPECT_TRUE(f.contains_box({-1, -1, 5}, {1, 1, 7}));
  EXPECT_FALSE(f.intersects_box({-1, -1, -7}, {1, 1, -5}));   // behind
  EXPECT_FALSE(f.intersects_box({-1, -1, 150}, {1, 1, 160}));  // beyond far
  EXPECT_TRUE(f.intersects_box({-100, -100, 50}, {100, 100, 60}));
  EXPECT_FALSE(f.contains_box({-100, -100, 50}, {100, 100, 60}));
}
