// View frustum as six inward-facing planes, extracted from a view-projection matrix
// (Gribb-Hartmann). Used by the chunk culler to reject boxes of space.
#pragma once
#include <Eigen/Core>
#include <array>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"

namespace chungs {

// Clip-space projection for a pinhole camera looking down +z (OpenCV axes): a point is visible iff
// -w <= x, y, z <= w for (x, y, z, w) = P * [p_cam; 1]; z maps near->-w, far->+w. Pixel edges
// (-0.5 and width-0.5) map to the clip borders.
Eigen::Matrix4d projection_matrix(const Camera& cam, double near, double far);
// Projection times world-to-camera for a camera-to-world pose.
Eigen::Matrix4d view_projection_matrix(const Camera& cam, const SE3& cam_to_world, double near, double far);

struct Frustum {
  // Plane i: n.dot(p) + d >= 0 inside; stored as (n, d) with |n| = 1.
  std::array<Eigen::Vector4d, 6> planes;

  static Frustum from_view_projection(const Eigen::Matrix4d& vp);
  bool contains(const Eigen::Vector3d& p) const;
  // Conservative box test: false only when the axis-aligned box lies fully outside one plane.
  bool intersects_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const;
  // True when the box lies fully inside all planes.
  bool contains_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const;
};

}  // namespace chungs
