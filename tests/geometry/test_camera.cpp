#include <gtest/gtest.h>

#include <random>

#include "chungs/common/error.hpp"
#include "chungs/geometry/camera.hpp"

using namespace chungs;

namespace {
Camera euroc_like() {
  Camera c(752, 480, 458.654, 457.296, 367.215, 248.375);
  c.dist = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0};
  return c;
}
}  // namespace

TEST(Camera, UndistortInvertsDistortInsideImage) {
  Camera c = euroc_like();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 500; ++i) {
    Eigen::Vector2d px(u(rng) * (c.width - 1), u(rng) * (c.height - 1));
    Eigen::Vector3d p = c.unproject(px, 2.0 + u(rng));
    EXPECT_LT((c.project(p) - px).norm(), 1e-6) << px.transpose();
  }
}

TEST(Camera, DistortMatchesHandFormula) {
  Camera c = euroc_like();
  c.dist[4] = 0.01;
  Eigen::Vector2d x(0.31, -0.17);
  double r2 = x.squaredNorm();
  double rad = 1 + c.dist[0] * r2 + c.dist[1] * r2 * r2 + c.dist[4] * r2 * r2 * r2;
  double xd = x.x() * rad + 2 * c.dist[2] * x.x() * x.y() + c.dist[3] * (r2 + 2 * x.x() * x.x());
  double yd = x.y() * rad + c.dist[2] * (r2 + 2 * x.y() * x.y()) + 2 * c.dist[3] * x.x() * x.y();
  EXPECT_NEAR(c.distort(x).x(), xd, 1e-15);
  EXPECT_NEAR(c.distort(x).y(), yd, 1e-15);
}

TEST(Camera, ScaledKeepsPixelCentresConsistent) {
  Camera c(640, 480, 525, 525, 319.5, 239.5);
  Camera h = c.scaled(0.5);
  EXPECT_EQ(h.width, 320);
  EXPECT_DOUBLE_EQ(h.cx, 159.5);
  Eigen::Vector3d p(0.3, -0.2, 2.0);
  Eigen::Vector2d a = c.project(p), b = h.project(p);
  EXPECT_NEAR((a.x() + 0.5) * 0.5 - 0.5, b.x(), 1e-12);
}

TEST(Camera, ValidateNamesTheSource) {
  Camera c(0, 480, 525, 525, 319.5, 239.5);
  try {
    c.validate("calib.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("calib.txt"), std::string::npos);
  }
}

// Finite but absurd intrinsics (fx or cx 1e308 in a calibration file) passed: a run then sampled
// nothing, or failed far away naming neither the file nor the field.
TEST(Camera, ValidateRefusesFocalLengthsAndPrincipalPointsNoCameraHas) {
  const auto said = [](const Camera& c) {
    try {
      c.validate("cam.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(said(Camera(640, 480, 525, 525, 319.5, 239.5)), "");
  EXPECT_EQ(said(Camera(640, 480, 525, 525, -600, 900)), "");  // a crop of a larger image: within an image
  EXPECT_NE(said(Camera(640, 480, 1e308, 525, 319.5, 239.5)).find("focal"), std::string::npos);
  EXPECT_NE(said(Camera(640, 480, 525, 7e6, 319.5, 239.5)).find("focal"), std::string::npos);
  EXPECT_NE(said(Camera(640, 480, 525, 525, 1e308, 239.5)).find("principal point"), std::string::npos);
  EXPECT_NE(said(Camera(640, 480, 525, 525, 319.5, -481)).find("principal point"), std::string::npos);
  EXPECT_NE(said(Camera(640, 480, 525, 525, 1281, 239.5)).find("cam.yaml"), std::string::npos);
}
