#include "chungs/geometry/camera.hpp"

#include <Eigen/LU>
#include <cmath>
#include <sstream>

#include "chungs/common/error.hpp"

namespace chungs {

bool Camera::distorted() const {
  for (double d : dist)
    if (d != 0) return true;
  return false;
}

void Camera::validate(const std::string& what) const {
  if (width <= 0 || height <= 0) fail(what, ": image size must be positive, got ", width, "x", height);
  for (double v : {fx, fy, cx, cy})
    if (!std::isfinite(v)) fail(what, ": non-finite intrinsics");
  if (fx <= 0 || fy <= 0) fail(what, ": focal lengths must be positive, got fx=", fx, " fy=", fy);
  // Finite but absurd values (fx or cx 1e308) passed: a run then sampled nothing, or failed far away
  // with a point "outside the chunk id range". A field of view under ~0.01 degrees, or a principal
  // point more than an image away from the image, is no camera's.
  if (fx > 1e4 * width || fy > 1e4 * height)
    fail(what, ": focal lengths beyond 10000 x the image size, got fx=", fx, " fy=", fy, " for ", width, "x", height);
  if (cx < -width || cx > 2.0 * width || cy < -height || cy > 2.0 * height)
    fail(what, ": principal point (", cx, ", ", cy, ") lies more than an image away from the ", width, "x", height,
         " image");
  for (double d : dist)
    if (!std::isfinite(d)) fail(what, ": non-finite distortion coefficient");
}

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Eigen::Vector2d Camera::distort(const Eigen::Vector2d& xn) const {
  const auto [k1, k2, p1, p2, k3] = dist;
  double x = xn.x(), y = xn.y();
  double r2 = x * x + y * y;
  double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
          y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

Eigen::Vector2d Camera::undistort(const Eigen::Vector2d& xd) const {
  if (!distorted()) return xd;
  // Gauss-Newton on distort(x) = xd with a numerical Jacobian; converges in a few steps for real
  // lenses (|distortion| well below 1 inside the image).
  Eigen::Vector2d x = xd;
  for (int it = 0; it < 20; ++it) {
    Eigen::Vector2d r = distort(x) - xd;
    if (r.squaredNorm() < 1e-24) break;
    const double h = 1e-7;
    Eigen::Matrix2d J;
    J.col(0) = (distort(x + Eigen::Vector2d(h, 0)) - distort(x - Eigen::Vector2d(h, 0))) / (2 * h);
    J.col(1) = (distort(x + Eigen::Vector2d(0, h)) - distort(x - Eigen::Vector2d(0, h))) / (2 * h);
    x -= J.inverse() * r;
  }
  return x;
}

Eigen::Vector2d Camera::project(const Eigen::Vector3d& p) const {
  Eigen::Vector2d xn(p.x() / p.z(), p.y() / p.z());
  Eigen::Vector2d xd = distorted() ? distort(xn) : xn;
  return {fx * xd.x() + cx, fy * xd.y() + cy};
}

Eigen::Vector3d Camera::unproject(const Eigen::Vector2d& px, double depth) const {
  Eigen::Vector2d xd((px.x() - cx) / fx, (px.y() - cy) / fy);
  Eigen::Vector2d xn = undistort(xd);
  return {xn.x() * depth, xn.y() * depth, depth};
}

bool Camera::in_image(const Eigen::Vector2d& px, double border) const {
  return px.x() >= -0.5 + border && px.y() >= -0.5 + border && px.x() < width - 0.5 - border &&
         px.y() < height - 0.5 - border;
}

Camera Camera::scaled(double f) const {
  Camera c = *this;
  c.width = int(std::lround(width * f));
  c.height = int(std::lround(height * f));
  c.fx = fx * f;
  c.fy = fy * f;
  // Pixel centres at integers: continuous coordinate u maps to (u + 0.5) * f - 0.5.
  c.cx = (cx + 0.5) * f - 0.5;
  c.cy = (cy + 0.5) * f - 0.5;
  return c;
}

std::string Camera::describe() const {
  std::ostringstream os;
  os << width << "x" << height << " fx=" << fx << " fy=" << fy << " cx=" << cx << " cy=" << cy;
  if (distorted())
    os << " dist=[" << dist[0] << " " << dist[1] << " " << dist[2] << " " << dist[3] << " " << dist[4] << "]";
  return os.str();
}

}  // namespace chungs
