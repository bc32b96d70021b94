// Two-view initialisation of a monocular map (issue 25) on synthetic correspondences with known geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "chungs/tracking/mono_init.hpp"

namespace chungs::tracking {
namespace {

constexpr int kW = 640, kH = 480;
const Intrinsics kK{500, 500, 320, 240, 0};

struct Scene {
  std::vector<cv::Point2f> p1, p2;
  std::vector<Eigen::Vector3d> X;  // first camera's frame, of the points that project into both views
};

// Projects world points (= first camera frame) into both views with pixel noise.
Scene project(const std::vector<Eigen::Vector3d>& pts, const SE3& T21, double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, noise_px);
  Scene s;
  for (const auto& X : pts) {
    const Eigen::Vector3d Y = T21 * X;
    if (X.z() <= 0.1 || Y.z() <= 0.1) continue;
    const cv::Point2f a(float(kK.fx * X.x() / X.z() + kK.cx + n(rng)), float(kK.fy * X.y() / X.z() + kK.cy + n(rng)));
    const cv::Point2f b(float(kK.fx * Y.x() / Y.z() + kK.cx + n(rng)), float(kK.fy * Y.y() / Y.z() + kK.cy + n(rng)));
    if (a.x < 0 || a.y < 0 || a.x >= kW || a.y >= kH || b.x < 0 || b.y < 0 || b.x >= kW || b.y >= kH) continue;
    s.p1.push_back(a), s.p2.push_back(b), s.X.push_back(X);
  }
  return s;
}

// The second camera 0.6 m to the right and a little forward, turned 4 degrees about the vertical.
SE3 motion() {
  const SE3 T_w2(Eigen::Quaterniond(Eigen::AngleAxisd(4 * M_PI / 180, Eigen::Vector3d::UnitY())),
                 Eigen::Vector3d(0.6, 0.05, 0.2));
  return T_w2.inverse();
}

std::vector<Eigen::Vector3d> box_points(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-4, 4), y(-3, 3), z(4, 14);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i) out.emplace_back(x(rng), y(rng), z(rng));
  return out;
}

// A tilted plane (a wall seen at an angle) 4-9 m away.
std::vector<Eigen::Vector3d> plane_points(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-4, 4), y(-3, 3);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i) {
    const double u = x(rng), v = y(rng);
    out.emplace_back(u, v, 6.5 + 0.6 * u + 0.2 * v);
  }
  return out;
}

double rotation_error_deg(const SE3& a, const SE3& b) { return a.q.angularDistance(b.q) * 180 / M_PI; }
double direction_error_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}
double median_z(const std::vector<Eigen::Vector3d>& pts) {
  std::vector<double> z;
  for (auto& p : pts) z.push_back(p.z());
  std::nth_element(z.begin(), z.begin() + long(z.size() / 2), z.end());
  return z[z.size() / 2];
}

TEST(MonoInit, GeneralSceneChoosesFundamentalAndRecoversMotion) {
  const SE3 T21 = motion();
  const Scene s = project(box_points(600, 3), T21, 0.5, 4);
  const TwoViewResult r = two_view_geometry(s.p1, s.p2, {}, kK);
  ASSERT_TRUE(r.ok) << r.why;
  EXPECT_EQ(r.model, TwoViewModel::Fundamental) << "S_H " << r.score_h << " S_F " << r.score_f;
  EXPECT_LT(rotation_error_deg(r.T_21, T21), 0.3);
  EXPECT_LT(direction_error_deg(r.T_21.t, T21.t), 3.0);
  EXPECT_GE(double(r.points.size()), 0.8 * double(s.p1.size())) << s.p1.size() << " matches";
}

TEST(MonoInit, PlanarSceneChoosesHomographyAndRecoversMotion) {
  const SE3 T21 = motion();
  const Scene s = project(plane_points(500, 5), T21, 0.5, 6);
  const TwoViewResult r = two_view_geometry(s.p1, s.p2, {}, kK);
  ASSERT_TRUE(r.ok) << r.why;
  EXPECT_EQ(r.model, TwoViewModel::Homography) << "S_H " << r.score_h << " S_F " << r.score_f;
  EXPECT_LT(rotation_error_deg(r.T_21, T21), 0.5);
  EXPECT_LT(direction_error_deg(r.T_21.t, T21.t), 3.0);
}

TEST(MonoInit, ScaleIsMedianDepthOfTheFirstViewAndPointsMatchTruth) {
  const SE3 T21 = motion();
  const Scene s = project(box_points(600, 7), T21, 0.3, 8);
  const TwoViewResult r = two_view_geometry(s.p1, s.p2, {}, kK);
  ASSERT_TRUE(r.ok) << r.why;
  EXPECT_NEAR(median_z(r.points), 1.0, 1e-9);
  // In the map's unit, the true scene is the truth divided by its median depth: baseline and points agree.
  std::vector<Eigen::Vector3d> truth;
  for (int i : r.used) truth.push_back(s.X[size_t(i)]);
  const double unit = median_z(truth);
  EXPECT_NEAR(r.T_21.t.norm(), T21.t.norm() / unit, 0.05 * T21.t.norm() / unit);
  double worst = 0;
  for (size_t j = 0; j < r.used.size(); ++j)
    worst = std::max(worst, (r.points[j] - s.X[size_t(r.used[j])] / unit).norm() / (s.X[size_t(r.used[j])].norm() / unit));
  EXPECT_LT(worst, 0.15);  // relative position error of the worst point (0.3 px noise, >= 1 deg parallax)

  TwoViewOptions o;
  o.target_median_depth = 7.5;
  const TwoViewResult r2 = two_view_geometry(s.p1, s.p2, {}, kK, o);
  ASSERT_TRUE(r2.ok) << r2.why;
  EXPECT_NEAR(median_z(r2.points), 7.5, 1e-9);
}

TEST(MonoInit, RefusesWithoutParallaxOrMatches) {
  // A pure rotation: everything fits a homography but nothing can be triangulated.
  const SE3 rot(Eigen::Quaterniond(Eigen::AngleAxisd(3 * M_PI / 180, Eigen::Vector3d::UnitY())), Eigen::Vector3d(0, 0, 0.001));
  const Scene s = project(box_points(600, 9), rot.inverse(), 0.5, 10);
  const TwoViewResult r = two_view_geometry(s.p1, s.p2, {}, kK);
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.why.empty());
  EXPECT_TRUE(r.points.empty());

  const Scene few = project(box_points(60, 11), motion(), 0.5, 12);
  const TwoViewResult r3 = two_view_geometry(few.p1, few.p2, {}, kK);
  EXPECT_FALSE(r3.ok);
  EXPECT_NE(r3.why.find("matches"), std::string::npos) << r3.why;
  EXPECT_THROW(two_view_geometry(few.p1, {}, {}, kK), Error);
}

TEST(MonoInit, OutliersDoNotChangeTheChoiceOrTheMotion) {
  const SE3 T21 = motion();
  Scene s = project(box_points(600, 13), T21, 0.5, 14);
  std::mt19937 rng(15);
  std::uniform_real_distribution<float> u(0, kW), v(0, kH);
  for (size_t i = 0; i < s.p2.size(); i += 4) s.p2[i] = cv::Point2f(u(rng), v(rng));  // 25 % wrong matches
  const TwoViewResult r = two_view_geometry(s.p1, s.p2, {}, kK);
  ASSERT_TRUE(r.ok) << r.why;
  EXPECT_EQ(r.model, TwoViewModel::Fundamental);
  EXPECT_LT(rotation_error_deg(r.T_21, T21), 0.5);
  EXPECT_LT(direction_error_deg(r.T_21.t, T21.t), 4.0);
}

}  // namespace
}  // namespace chungs::tracking
