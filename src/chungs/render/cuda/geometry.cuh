// Device twin of cpu/gaussian_geometry.hpp and sh.hpp: the per-Gaussian forward intermediates,
// recomputed by the backward. Float only; same formulas and evaluation order as the CPU twin.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/render/cuda/kernels.cuh"
#include "chungs/render/gaussian_view.hpp"

namespace chungs::cuda::detail {

// Real SH basis, degree 3, in the 3DGS convention (cpu: chungs::sh::basis); entries above the
// configured degree are zero so loops stay unrolled over all 16.
__device__ __forceinline__ void sh_basis(int degree, float x, float y, float z, float* b) {
  const float c1 = 0.4886025119029199f;
  const float xx = x * x, yy = y * y, zz = z * z;
  b[0] = 0.28209479177387814f;
  b[1] = -c1 * y;
  b[2] = c1 * z;
  b[3] = -c1 * x;
  b[4] = 1.0925484305920792f * x * y;
  b[5] = -1.0925484305920792f * y * z;
  b[6] = 0.31539156525252005f * (2 * zz - xx - yy);
  b[7] = -1.0925484305920792f * x * z;
  b[8] = 0.5462742152960396f * (xx - yy);
  b[9] = -0.5900435899266435f * y * (3 * xx - yy);
  b[10] = 2.890611442640554f * x * y * z;
  b[11] = -0.4570457994644658f * y * (4 * zz - xx - yy);
  b[12] = 0.3731763325901154f * z * (2 * zz - 3 * xx - 3 * yy);
  b[13] = -0.4570457994644658f * x * (4 * zz - xx - yy);
  b[14] = 1.445305721320277f * z * (xx - yy);
  b[15] = -0.5900435899266435f * x * (xx - 3 * yy);
  const int nb = (degree + 1) * (degree + 1);
#pragma unroll
  for (int k = 1; k < kShCoeffs; ++k)
    if (k >= nb) b[k] = 0.f;
}

// d basis_k / d(x, y, z) contracted with per-coefficient weights gk[k]: returns sum_k gk[k] db_k.
__device__ __forceinline__ void sh_basis_vjp(float x, float y, float z, const float* gk, float* gd) {
  const float c1 = 0.4886025119029199f;
  const float xx = x * x, yy = y * y, zz = z * z;
  float gx = 0, gy = 0, gz = 0;
  gy += gk[1] * -c1;
  gz += gk[2] * c1;
  gx += gk[3] * -c1;
  float c = 1.0925484305920792f;
  gx += gk[4] * c * y, gy += gk[4] * c * x;
  c = -1.0925484305920792f;
  gy += gk[5] * c * z, gz += gk[5] * c * y;
  c = 0.31539156525252005f;
  gx += gk[6] * c * -2 * x, gy += gk[6] * c * -2 * y, gz += gk[6] * c * 4 * z;
  c = -1.0925484305920792f;
  gx += gk[7] * c * z, gz += gk[7] * c * x;
  c = 0.5462742152960396f;
  gx += gk[8] * c * 2 * x, gy += gk[8] * c * -2 * y;
  c = -0.5900435899266435f;
  gx += gk[9] * c * 6 * x * y, gy += gk[9] * c * 3 * (xx - yy);
  c = 2.890611442640554f;
  gx += gk[10] * c * y * z, gy += gk[10] * c * x * z, gz += gk[10] * c * x * y;
  c = -0.4570457994644658f;
  gx += gk[11] * c * -2 * x * y, gy += gk[11] * c * (4 * zz - xx - 3 * yy), gz += gk[11] * c * 8 * y * z;
  c = 0.3731763325901154f;
  gx += gk[12] * c * -6 * x * z, gy += gk[12] * c * -6 * y * z, gz += gk[12] * c * (6 * zz - 3 * xx - 3 * yy);
  c = -0.4570457994644658f;
  gx += gk[13] * c * (4 * zz - 3 * xx - yy), gy += gk[13] * c * -2 * x * y, gz += gk[13] * c * 8 * x * z;
  c = 1.445305721320277f;
  gx += gk[14] * c * 2 * x * z, gy += gk[14] * c * -2 * y * z, gz += gk[14] * c * (xx - yy);
  c = -0.5900435899266435f;
  gx += gk[15] * c * 3 * (xx - yy), gy += gk[15] * c * -6 * x * y;
  gd[0] = gx, gd[1] = gy, gd[2] = gz;
}

struct Geometry {
  float pc[3];
  float qn[4], qnorm;
  float Rq[9];
  float s[3];
  float Sigma[9];
  float rx, ry;
  bool clamp_x, clamp_y;
  float Tm[6];
  float A, B, C, det;
  // The determinant without the low-pass, and the anti-aliased opacity factor (as the CPU twin).
  float det0, comp;
  float dir[3], dist;
  float raw[3];
  float opacity;
};

// What flows through comp into the 2D covariance's gradient (the CPU twin's comp_backward).
__device__ __forceinline__ void comp_backward(const Geometry& o, float low_pass, float gcomp, float& gA,
                                              float& gB, float& gC) {
  if (!(o.det0 > 1e-6f * o.det)) return;
  const float h = 0.5f * gcomp * o.comp;
  gA += h * ((o.C - low_pass) / o.det0 - o.C / o.det);
  gC += h * ((o.A - low_pass) / o.det0 - o.A / o.det);
  gB += h * (o.B / o.det - o.B / o.det0);
}

// The SH coefficients of one slot (48 floats, 16-byte aligned when the array is).
__device__ __forceinline__ void load_sh(const float* sh, uint32_t slot, float* out) {
  const float4* p = reinterpret_cast<const float4*>(sh + size_t(kShFloats) * slot);
#pragma unroll
  for (int i = 0; i < kShFloats / 4; ++i) {
    const float4 v = __ldg(p + i);
    out[4 * i] = v.x, out[4 * i + 1] = v.y, out[4 * i + 2] = v.z, out[4 * i + 3] = v.w;
  }
}

// False when the Gaussian cannot be rendered (as the CPU twin). shc: the slot's SH coefficients;
// basis: out, 16 values.
__device__ __forceinline__ bool compute_geometry(const GaussianArrays<float>& g, uint32_t slot,
                                                 const RenderCamera<float>& cam, const RasterConsts& k,
                                                 const float* shc, float* basis, Geometry& o) {
  const float* p = g.mean + 3 * size_t(slot);
  const float p0 = __ldg(p), p1 = __ldg(p + 1), p2 = __ldg(p + 2);
  const float* R = cam.R;
#pragma unroll
  for (int r = 0; r < 3; ++r) o.pc[r] = R[3 * r] * p0 + R[3 * r + 1] * p1 + R[3 * r + 2] * p2 + cam.t[r];
  const float x = o.pc[0], y = o.pc[1], z = o.pc[2];
  if (!(z >= k.near_plane)) return false;

  const float4 q = __ldg(reinterpret_cast<const float4*>(g.rotation) + slot);
  o.qnorm = sqrtf(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!(o.qnorm > 0.f)) return false;
  o.qn[0] = q.x / o.qnorm, o.qn[1] = q.y / o.qnorm, o.qn[2] = q.z / o.qnorm, o.qn[3] = q.w / o.qnorm;
  const float qw = o.qn[0], qx = o.qn[1], qy = o.qn[2], qz = o.qn[3];
  float* M = o.Rq;
  M[0] = 1 - 2 * (qy * qy + qz * qz), M[1] = 2 * (qx * qy - qw * qz), M[2] = 2 * (qx * qz + qw * qy);
  M[3] = 2 * (qx * qy + qw * qz), M[4] = 1 - 2 * (qx * qx + qz * qz), M[5] = 2 * (qy * qz - qw * qx);
  M[6] = 2 * (qx * qz - qw * qy), M[7] = 2 * (qy * qz + qw * qx), M[8] = 1 - 2 * (qx * qx + qy * qy);

  const float* ls = g.log_scale + 3 * size_t(slot);
#pragma unroll
  for (int a = 0; a < 3; ++a) o.s[a] = expf(__ldg(ls + a));
#pragma unroll
  for (int r = 0; r < 3; ++r)
#pragma unroll
    for (int c = r; c < 3; ++c) {
      float v = 0;
#pragma unroll
      for (int a = 0; a < 3; ++a) v += M[3 * r + a] * M[3 * c + a] * o.s[a] * o.s[a];
      o.Sigma[3 * r + c] = o.Sigma[3 * c + r] = v;
    }

  const float W = float(cam.width), H = float(cam.height), gb = k.guard_band;
  const float lo_x = (W / 2 - gb * W / 2 - cam.cx) / cam.fx, hi_x = (W / 2 + gb * W / 2 - cam.cx) / cam.fx;
  const float lo_y = (H / 2 - gb * H / 2 - cam.cy) / cam.fy, hi_y = (H / 2 + gb * H / 2 - cam.cy) / cam.fy;
  const float ux = x / z, uy = y / z;
  o.clamp_x = ux < lo_x || ux > hi_x;
  o.clamp_y = uy < lo_y || uy > hi_y;
  o.rx = fminf(fmaxf(ux, lo_x), hi_x);
  o.ry = fminf(fmaxf(uy, lo_y), hi_y);
  const float J00 = cam.fx / z, J02 = -cam.fx * o.rx / z, J11 = cam.fy / z, J12 = -cam.fy * o.ry / z;
#pragma unroll
  for (int c = 0; c < 3; ++c) {
    o.Tm[c] = J00 * R[c] + J02 * R[6 + c];
    o.Tm[3 + c] = J11 * R[3 + c] + J12 * R[6 + c];
  }
  float TS[6];
#pragma unroll
  for (int r = 0; r < 2; ++r)
#pragma unroll
    for (int c = 0; c < 3; ++c)
      TS[3 * r + c] =
          o.Tm[3 * r] * o.Sigma[c] + o.Tm[3 * r + 1] * o.Sigma[3 + c] + o.Tm[3 * r + 2] * o.Sigma[6 + c];
  o.A = TS[0] * o.Tm[0] + TS[1] * o.Tm[1] + TS[2] * o.Tm[2] + k.low_pass;
  o.B = TS[0] * o.Tm[3] + TS[1] * o.Tm[4] + TS[2] * o.Tm[5];
  o.C = TS[3] * o.Tm[3] + TS[4] * o.Tm[4] + TS[5] * o.Tm[5] + k.low_pass;
  o.det = o.A * o.C - o.B * o.B;
  if (!(o.det > 0.f)) return false;
  o.det0 = (o.A - k.low_pass) * (o.C - k.low_pass) - o.B * o.B;
  o.comp = k.antialias ? (o.det0 > 0.f ? sqrtf(o.det0 / o.det) : 0.f) : 1.f;

  float v[3] = {p0 - cam.centre[0], p1 - cam.centre[1], p2 - cam.centre[2]};
  o.dist = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(o.dist > 0.f)) return false;
#pragma unroll
  for (int a = 0; a < 3; ++a) o.dir[a] = v[a] / o.dist;
  sh_basis(k.sh_degree, o.dir[0], o.dir[1], o.dir[2], basis);
#pragma unroll
  for (int c = 0; c < 3; ++c) {
    float acc = 0.5f;
#pragma unroll
    for (int b = 0; b < kShCoeffs; ++b) acc += basis[b] * shc[3 * b + c];
    o.raw[c] = acc;
  }
  o.opacity = 1.f / (1.f + expf(-__ldg(g.opacity + slot)));
  return true;
}

}  // namespace chungs::cuda::detail
