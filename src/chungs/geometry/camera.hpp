// The one camera type: pinhole intrinsics with optional radial-tangential (Brown-Conrady, OpenCV
// order k1 k2 p1 p2 k3) distortion. Pixel centres are at integer coordinates (OpenCV convention).
#pragma once
#include <Eigen/Core>
#include <array>
#include <string>

namespace chungs {

struct Camera {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> dist{0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3

  Camera() = default;
  Camera(int w, int h, double fx_, double fy_, double cx_, double cy_) : width(w), height(h), fx(fx_), fy(fy_), cx(cx_), cy(cy_) {}

  bool distorted() const;
  // Throws Error naming `what` when size or focal lengths are not positive and finite.
  void validate(const std::string& what) const;
  Eigen::Matrix3d K() const;

  // Normalised image plane <-> pixels, with distortion applied / removed.
  Eigen::Vector2d distort(const Eigen::Vector2d& xn) const;
  Eigen::Vector2d undistort(const Eigen::Vector2d& xd) const;  // iterative inverse of distort()
  Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const;  // camera frame (z forward) -> pixel
  Eigen::Vector3d unproject(const Eigen::Vector2d& px, double depth) const;  // pixel + z -> camera
  bool in_image(const Eigen::Vector2d& px, double border = 0) const;

  // Same camera for an image resized by `factor` (pixel centres stay consistent).
  Camera scaled(double factor) const;
  std::string describe() const;
};

}  // namespace chungs
