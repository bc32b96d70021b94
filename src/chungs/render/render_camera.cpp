#include "chungs/render/render_camera.hpp"

#include "chungs/common/error.hpp"
#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"

namespace chungs {

template <typename T>
RenderCamera<T> make_render_camera(const Camera& camera, const SE3& T_wc) {
  camera.validate("render camera");
  if (camera.distorted())
    fail("render camera: ", camera.describe(),
         " has distortion coefficients; the rasterizer is pinhole, "
         "undistort the images first");
  if (!T_wc.t.allFinite() || !T_wc.q.coeffs().allFinite()) fail("render camera: pose is not finite");
  RenderCamera<T> c;
  c.width = camera.width;
  c.height = camera.height;
  c.fx = T(camera.fx), c.fy = T(camera.fy), c.cx = T(camera.cx), c.cy = T(camera.cy);
  const SE3 T_cw = T_wc.inverse();
  const Eigen::Matrix3d R = T_cw.rotation();
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) c.R[3 * r + k] = T(R(r, k));
    c.t[r] = T(T_cw.t[r]);
    c.centre[r] = T(T_wc.t[r]);
  }
  return c;
}

template RenderCamera<float> make_render_camera<float>(const Camera&, const SE3&);
template RenderCamera<double> make_render_camera<double>(const Camera&, const SE3&);

}  // namespace chungs
