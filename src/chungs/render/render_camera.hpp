// The camera as the rasterizer sees it: pinhole intrinsics and the world-to-camera transform in the
// scalar type of the render, without Eigen (keeps the renderer's compile units lean).
#pragma once

namespace chungs {

struct Camera;
struct SE3;

template <typename T>
struct RenderCamera {
  int width = 0, height = 0;
  T fx = 0, fy = 0, cx = 0, cy = 0;      // pixel (u, v) has its centre at (u, v)
  T R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // world-to-camera rotation, row-major
  T t[3] = {0, 0, 0};                    // world-to-camera translation
  T centre[3] = {0, 0, 0};               // camera centre in the world
};

// From the project's Camera and a camera-to-world pose. The rasterizer is a pinhole renderer: a
// camera with distortion coefficients throws Error (undistort the images first), as do invalid
// intrinsics.
template <typename T>
RenderCamera<T> make_render_camera(const Camera& camera, const SE3& T_wc);

}  // namespace chungs
