// Backward of the per-Gaussian stage (twin of cpu/projection_backward.cpp): splat gradients to the
// mean, log-scale, quaternion, opacity logit and SH coefficients, recomputing the forward geometry.
#include "chungs/render/cuda/geometry.cuh"

namespace chungs::cuda::detail {

namespace {

__device__ __forceinline__ void quat_backward(const float* q, const float* gR, float* gq) {
  const float w = q[0], x = q[1], y = q[2], z = q[3];
  gq[0] = 2 * (-z * gR[1] + y * gR[2] + z * gR[3] - x * gR[5] - y * gR[6] + x * gR[7]);
  gq[1] = 2 * (y * gR[1] + z * gR[2] + y * gR[3] - 2 * x * gR[4] - w * gR[5] + z * gR[6] + w * gR[7] -
               2 * x * gR[8]);
  gq[2] = 2 * (-2 * y * gR[0] + x * gR[1] + w * gR[2] + x * gR[3] + z * gR[5] - w * gR[6] + z * gR[7] -
               2 * y * gR[8]);
  gq[3] = 2 * (-2 * z * gR[0] - w * gR[1] + x * gR[2] + w * gR[3] - 2 * z * gR[4] + y * gR[5] + x * gR[6] +
               y * gR[7]);
}

__global__ void __launch_bounds__(128)
    gaussian_backward_kernel(GaussianArrays<float> g, const uint32_t* __restrict__ ids, uint32_t n,
                             RenderCamera<float> cam, RasterConsts k, const uint8_t* __restrict__ visible,
                             const float* __restrict__ splat_grads, DeviceGaussianGrads out) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= n) return;
  float4* gsh4 = reinterpret_cast<float4*>(out.sh + size_t(kShFloats) * j);
  float shc[kShFloats], basis[kShCoeffs];
  Geometry o;
  const uint32_t slot = ids[j];
  bool ok = visible[j] != 0;
  if (ok) {
    load_sh(g.sh, slot, shc);
    ok = compute_geometry(g, slot, cam, k, shc, basis, o);
  }
  if (!ok) {
    for (int a = 0; a < 3; ++a) out.mean[3 * j + a] = 0.f, out.log_scale[3 * j + a] = 0.f;
    reinterpret_cast<float4*>(out.rotation)[j] = make_float4(0, 0, 0, 0);
    out.opacity[j] = 0.f;
#pragma unroll
    for (int i = 0; i < kShFloats / 4; ++i) gsh4[i] = make_float4(0, 0, 0, 0);
    return;
  }
  float gs[kSplatGrads];
#pragma unroll
  for (int i = 0; i < kSplatGrads; ++i) gs[i] = splat_grads[size_t(j) * kSplatGrads + i];
  const float* R = cam.R;
  const float x = o.pc[0], y = o.pc[1], z = o.pc[2];
  float gpc[3] = {0, 0, 0}, gmean[3] = {0, 0, 0};

  out.opacity[j] = gs[5] * o.comp * o.opacity * (1 - o.opacity);

  // Colour: SH coefficients and, through the viewing direction, the mean.
  const float graw[3] = {o.raw[0] > 0 ? gs[6] : 0.f, o.raw[1] > 0 ? gs[7] : 0.f, o.raw[2] > 0 ? gs[8] : 0.f};
#pragma unroll
  for (int i = 0; i < kShFloats / 4; ++i) {
    float v[4];
#pragma unroll
    for (int e = 0; e < 4; ++e) v[e] = graw[(4 * i + e) % 3] * basis[(4 * i + e) / 3];
    gsh4[i] = make_float4(v[0], v[1], v[2], v[3]);
  }
  if (k.sh_degree > 0) {
    const int nb = (k.sh_degree + 1) * (k.sh_degree + 1);
    float gk[kShCoeffs];
    gk[0] = 0.f;
#pragma unroll
    for (int b = 1; b < kShCoeffs; ++b)
      gk[b] = b < nb ? graw[0] * shc[3 * b] + graw[1] * shc[3 * b + 1] + graw[2] * shc[3 * b + 2] : 0.f;
    float gdir[3];
    sh_basis_vjp(o.dir[0], o.dir[1], o.dir[2], gk, gdir);
    const float d = gdir[0] * o.dir[0] + gdir[1] * o.dir[1] + gdir[2] * o.dir[2];
#pragma unroll
    for (int a = 0; a < 3; ++a) gmean[a] += (gdir[a] - d * o.dir[a]) / o.dist;
  }

  // Conic -> 2D covariance: dL/dSigma2 = -K dL/dK K, with the off-diagonal gradient split in two.
  const float ka = o.C / o.det, kb = -o.B / o.det, kc = o.A / o.det;
  const float Ga = gs[2], Gb = gs[3] / 2, Gc = gs[4];
  const float KG00 = ka * Ga + kb * Gb, KG01 = ka * Gb + kb * Gc, KG10 = kb * Ga + kc * Gb,
              KG11 = kb * Gb + kc * Gc;
  float gA = -(KG00 * ka + KG01 * kb), gB2 = -(KG00 * kb + KG01 * kc), gC = -(KG10 * kb + KG11 * kc);
  if (k.antialias) comp_backward(o, k.low_pass, gs[5] * o.opacity, gA, gB2, gC);
  const float G2[4] = {gA, gB2, gB2, gC};
  float G2T[6];
#pragma unroll
  for (int r = 0; r < 2; ++r)
#pragma unroll
    for (int c = 0; c < 3; ++c) G2T[3 * r + c] = G2[2 * r] * o.Tm[c] + G2[2 * r + 1] * o.Tm[3 + c];
  float gSigma[9];
#pragma unroll
  for (int r = 0; r < 3; ++r)
#pragma unroll
    for (int c = 0; c < 3; ++c) gSigma[3 * r + c] = o.Tm[r] * G2T[c] + o.Tm[3 + r] * G2T[3 + c];
  float gTm[6];
#pragma unroll
  for (int r = 0; r < 2; ++r)
#pragma unroll
    for (int c = 0; c < 3; ++c)
      gTm[3 * r + c] =
          2 * (G2T[3 * r] * o.Sigma[c] + G2T[3 * r + 1] * o.Sigma[3 + c] + G2T[3 * r + 2] * o.Sigma[6 + c]);
  const float gJ00 = gTm[0] * R[0] + gTm[1] * R[1] + gTm[2] * R[2];
  const float gJ02 = gTm[0] * R[6] + gTm[1] * R[7] + gTm[2] * R[8];
  const float gJ11 = gTm[3] * R[3] + gTm[4] * R[4] + gTm[5] * R[5];
  const float gJ12 = gTm[3] * R[6] + gTm[4] * R[7] + gTm[5] * R[8];
  const float z2 = z * z;
  gpc[2] += -gJ00 * cam.fx / z2 - gJ11 * cam.fy / z2;
  gpc[2] += gJ02 * cam.fx * o.rx / z2 + gJ12 * cam.fy * o.ry / z2;
  if (!o.clamp_x) {
    gpc[0] += -gJ02 * cam.fx / z2;
    gpc[2] += gJ02 * cam.fx * x / (z2 * z);
  }
  if (!o.clamp_y) {
    gpc[1] += -gJ12 * cam.fy / z2;
    gpc[2] += gJ12 * cam.fy * y / (z2 * z);
  }
  gpc[0] += gs[0] * cam.fx / z;
  gpc[1] += gs[1] * cam.fy / z;
  gpc[2] += -gs[0] * cam.fx * x / z2 - gs[1] * cam.fy * y / z2 + gs[9];
#pragma unroll
  for (int a = 0; a < 3; ++a) gmean[a] += R[a] * gpc[0] + R[3 + a] * gpc[1] + R[6 + a] * gpc[2];
#pragma unroll
  for (int a = 0; a < 3; ++a) out.mean[3 * j + a] = gmean[a];

  // Sigma = M M^T with M = Rq diag(s): dL/dM = 2 gSigma M.
  float gRq[9];
#pragma unroll
  for (int c = 0; c < 3; ++c) {
    float gs_c = 0;
#pragma unroll
    for (int r = 0; r < 3; ++r) {
      float gM = 0;
#pragma unroll
      for (int a = 0; a < 3; ++a) gM += gSigma[3 * r + a] * o.Rq[3 * a + c];
      gM *= 2 * o.s[c];
      gs_c += gM * o.Rq[3 * r + c];
      gRq[3 * r + c] = gM * o.s[c];
    }
    out.log_scale[3 * j + c] = gs_c * o.s[c];
  }
  float gqn[4];
  quat_backward(o.qn, gRq, gqn);
  const float d = gqn[0] * o.qn[0] + gqn[1] * o.qn[1] + gqn[2] * o.qn[2] + gqn[3] * o.qn[3];
  reinterpret_cast<float4*>(out.rotation)[j] =
      make_float4((gqn[0] - d * o.qn[0]) / o.qnorm, (gqn[1] - d * o.qn[1]) / o.qnorm,
                  (gqn[2] - d * o.qn[2]) / o.qnorm, (gqn[3] - d * o.qn[3]) / o.qnorm);
}

}  // namespace

void gaussian_backward(const GaussianArrays<float>& g, const uint32_t* ids, size_t n,
                       const RenderCamera<float>& cam, const RasterConsts& k, const uint8_t* visible,
                       const float* splat_grads, const DeviceGaussianGrads& out, cudaStream_t stream) {
  const unsigned blocks = unsigned((n + 127) / 128);
  gaussian_backward_kernel<<<blocks, 128, 0, stream>>>(g, ids, uint32_t(n), cam, k, visible, splat_grads,
                                                       out);
}

}  // namespace chungs::cuda::detail
