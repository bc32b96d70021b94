#include "chungs/geometry/frustum.hpp"

#include "chungs/common/error.hpp"

namespace chungs {

Eigen::Matrix4d projection_matrix(const Camera& cam, double near, double far) {
  if (!(near > 0) || !(far > near)) fail("frustum: need 0 < near < far, got near=", near, " far=", far);
  // u = fx x/z + cx in [-0.5, W-0.5]  <=>  x_clip = (2 fx x + (2 cx + 1 - W) z) / W in [-z, z].
  const double W = cam.width, H = cam.height;
  Eigen::Matrix4d P = Eigen::Matrix4d::Zero();
  P(0, 0) = 2 * cam.fx / W;
  P(0, 2) = (2 * cam.cx + 1 - W) / W;
  P(1, 1) = 2 * cam.fy / H;
  P(1, 2) = (2 * cam.cy + 1 - H) / H;
  P(2, 2) = (far + near) / (far - near);
  P(2, 3) = -2 * far * near / (far - near);
  P(3, 2) = 1;
  return P;
}

Eigen::Matrix4d view_projection_matrix(const Camera& cam, const SE3& cam_to_world, double near, double far) {
  return projection_matrix(cam, near, far) * cam_to_world.inverse().matrix();
}

Frustum Frustum::from_view_projection(const Eigen::Matrix4d& m) {
  Frustum f;
  const Eigen::RowVector4d r0 = m.row(0), r1 = m.row(1), r2 = m.row(2), r3 = m.row(3);
  const Eigen::RowVector4d rows[6] = {r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3 + r2, r3 - r2};
  for (int i = 0; i < 6; ++i) {
    Eigen::Vector4d p = rows[i].transpose();
    double n = p.head<3>().norm();
    if (!(n > 0)) fail("frustum: degenerate view-projection matrix");
    f.planes[i] = p / n;
  }
  return f;
}

bool Frustum::contains(const Eigen::Vector3d& p) const {
  for (const auto& pl : planes)
    if (pl.head<3>().dot(p) + pl.w() < 0) return false;
  return true;
}

bool Frustum::intersects_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const {
  for (const auto& pl : planes) {
    // The box corner furthest along the plane normal: if even it is outside, the box is.
    Eigen::Vector3d v((pl.x() >= 0 ? hi.x() : lo.x()), (pl.y() >= 0 ? hi.y() : lo.y()),
                      (pl.z() >= 0 ? hi.z() : lo.z()));
    if (pl.head<3>().dot(v) + pl.w() < 0) return false;
  }
  return true;
}

bool Frustum::contains_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const {
  for (const auto& pl : planes) {
    Eigen::Vector3d v((pl.x() >= 0 ? lo.x() : hi.x()), (pl.y() >= 0 ? lo.y() : hi.y()),
                      (pl.z() >= 0 ? lo.z() : hi.z()));
    if (pl.head<3>().dot(v) + pl.w() < 0) return false;
  }
  return true;
}

}  // namespace chungs
