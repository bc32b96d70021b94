// Forward intermediates of one Gaussian under one camera, shared by the projection and its backward
// (the backward recomputes them rather than storing ~60 numbers per Gaussian).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/render/gaussian_view.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_camera.hpp"
#include "chungs/render/sh.hpp"

namespace chungs::cpu {

template <typename T>
struct GaussianGeometry {
  T pc[3];         // mean in the camera frame
  T qn[4], qnorm;  // normalised quaternion (w, x, y, z) and the norm it had
  T Rq[9];         // rotation of the Gaussian, row-major
  T s[3];          // standard deviations
  T Sigma[9];      // 3D covariance, row-major (symmetric)
  T rx, ry;        // x/z and y/z, clamped to the guard band for the Jacobian
  bool clamp_x, clamp_y;
  T Tm[6];         // J * W, 2x3 row-major
  T A, B, C, det;  // 2D covariance [[A, B], [B, C]] (low-pass included) and its determinant
  T det0;          // the determinant without the low-pass
  T comp;          // opacity factor of the anti-aliased low-pass, sqrt(det0 / det) (1 without it)
  T dir[3], dist;  // unit direction camera centre -> mean, and the distance
  T raw[3];        // SH colour + 0.5 before the clamp at 0
  T basis[kShCoeffs];
  T opacity;  // sigmoid of the logit (the splat's is opacity * comp)
};

// Adds to the 2D covariance's gradient (gA, gB per off-diagonal entry, gC) what flows through comp, given
// dL/dcomp. Below det0 = 1e-6 det the splat is all but transparent (comp < 1e-3) and 1/det0 would blow
// up, so nothing flows there.
template <typename T>
inline void comp_backward(const GaussianGeometry<T>& o, T low_pass, T gcomp, T& gA, T& gB, T& gC) {
  if (!(o.det0 > T(1e-6) * o.det)) return;
  const T h = T(0.5) * gcomp * o.comp;  // d comp = comp / 2 (d ln det0 - d ln det)
  gA += h * ((o.C - low_pass) / o.det0 - o.C / o.det);
  gC += h * ((o.A - low_pass) / o.det0 - o.A / o.det);
  gB += h * (o.B / o.det - o.B / o.det0);
}

// False when the Gaussian cannot be rendered (behind the near plane, zero quaternion, degenerate
// covariance, mean at the camera centre).
template <typename T>
inline bool compute_geometry(const GaussianArrays<T>& g, uint32_t slot, const RenderCamera<T>& cam,
                             const RasterConfig& cfg, GaussianGeometry<T>& o) {
  const T* p = g.mean + 3 * size_t(slot);
  const T* R = cam.R;
  for (int r = 0; r < 3; ++r)
    o.pc[r] = R[3 * r] * p[0] + R[3 * r + 1] * p[1] + R[3 * r + 2] * p[2] + cam.t[r];
  const T x = o.pc[0], y = o.pc[1], z = o.pc[2];
  if (!(z >= T(cfg.near_plane))) return false;

  const T* q = g.rotation + 4 * size_t(slot);
  o.qnorm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(o.qnorm > T(0))) return false;
  for (int k = 0; k < 4; ++k) o.qn[k] = q[k] / o.qnorm;
  const T qw = o.qn[0], qx = o.qn[1], qy = o.qn[2], qz = o.qn[3];
  T* M = o.Rq;
  M[0] = 1 - 2 * (qy * qy + qz * qz), M[1] = 2 * (qx * qy - qw * qz), M[2] = 2 * (qx * qz + qw * qy);
  M[3] = 2 * (qx * qy + qw * qz), M[4] = 1 - 2 * (qx * qx + qz * qz), M[5] = 2 * (qy * qz - qw * qx);
  M[6] = 2 * (qx * qz - qw * qy), M[7] = 2 * (qy * qz + qw * qx), M[8] = 1 - 2 * (qx * qx + qy * qy);

  const T* ls = g.log_scale + 3 * size_t(slot);
  for (int k = 0; k < 3; ++k) o.s[k] = std::exp(ls[k]);
  // Sigma = Rq diag(s^2) Rq^T
  for (int r = 0; r < 3; ++r)
    for (int c = r; c < 3; ++c) {
      T v = 0;
      for (int k = 0; k < 3; ++k) v += M[3 * r + k] * M[3 * c + k] * o.s[k] * o.s[k];
      o.Sigma[3 * r + c] = o.Sigma[3 * c + r] = v;
    }

  // Jacobian of the perspective projection at the (guard-band clamped) mean.
  const T W = T(cam.width), H = T(cam.height), gb = T(cfg.guard_band);
  const T lo_x = (W / 2 - gb * W / 2 - cam.cx) / cam.fx, hi_x = (W / 2 + gb * W / 2 - cam.cx) / cam.fx;
  const T lo_y = (H / 2 - gb * H / 2 - cam.cy) / cam.fy, hi_y = (H / 2 + gb * H / 2 - cam.cy) / cam.fy;
  const T ux = x / z, uy = y / z;
  o.clamp_x = ux < lo_x || ux > hi_x;
  o.clamp_y = uy < lo_y || uy > hi_y;
  o.rx = std::clamp(ux, lo_x, hi_x);
  o.ry = std::clamp(uy, lo_y, hi_y);
  const T J00 = cam.fx / z, J02 = -cam.fx * o.rx / z, J11 = cam.fy / z, J12 = -cam.fy * o.ry / z;
  for (int c = 0; c < 3; ++c) {
    o.Tm[c] = J00 * R[c] + J02 * R[6 + c];
    o.Tm[3 + c] = J11 * R[3 + c] + J12 * R[6 + c];
  }
  T TS[6];  // Tm * Sigma
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c)
      TS[3 * r + c] =
          o.Tm[3 * r] * o.Sigma[c] + o.Tm[3 * r + 1] * o.Sigma[3 + c] + o.Tm[3 * r + 2] * o.Sigma[6 + c];
  o.A = TS[0] * o.Tm[0] + TS[1] * o.Tm[1] + TS[2] * o.Tm[2] + T(cfg.low_pass);
  o.B = TS[0] * o.Tm[3] + TS[1] * o.Tm[4] + TS[2] * o.Tm[5];
  o.C = TS[3] * o.Tm[3] + TS[4] * o.Tm[4] + TS[5] * o.Tm[5] + T(cfg.low_pass);
  o.det = o.A * o.C - o.B * o.B;
  if (!(o.det > T(0))) return false;
  const T lp = T(cfg.low_pass);
  o.det0 = (o.A - lp) * (o.C - lp) - o.B * o.B;
  o.comp = cfg.antialias ? (o.det0 > T(0) ? std::sqrt(o.det0 / o.det) : T(0)) : T(1);

  // Colour along the ray from the camera centre to the mean.
  T v[3];
  for (int k = 0; k < 3; ++k) v[k] = p[k] - cam.centre[k];
  o.dist = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(o.dist > T(0))) return false;
  for (int k = 0; k < 3; ++k) o.dir[k] = v[k] / o.dist;
  const int nb = sh_coeffs_for_degree(cfg.sh_degree);
  sh::basis(cfg.sh_degree, o.dir[0], o.dir[1], o.dir[2], o.basis);
  const T* shp = g.sh + size_t(kShFloats) * slot;
  for (int c = 0; c < 3; ++c) {
    T acc = T(0.5);
    for (int k = 0; k < nb; ++k) acc += o.basis[k] * shp[3 * k + c];
    o.raw[c] = acc;
  }
  o.opacity = T(1) / (T(1) + std::exp(-g.opacity[slot]));
  return true;
}

}  // namespace chungs::cpu
