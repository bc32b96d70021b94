// Backward of the per-Gaussian stage: splat gradients (mean in pixels, conic, opacity, colour, depth)
// to mean, log-scale, quaternion, opacity logit and SH coefficients.
#include <algorithm>
#include <cmath>

#include "chungs/render/cpu/gaussian_geometry.hpp"
#include "chungs/render/cpu/projection.hpp"

namespace chungs::cpu {

namespace {

// dL/dq for the rotation matrix of a unit quaternion, given dL/dRq (row-major).
template <typename T>
void quat_backward(const T* q, const T* gR, T* gq) {
  const T w = q[0], x = q[1], y = q[2], z = q[3];
  gq[0] = 2 * (-z * gR[1] + y * gR[2] + z * gR[3] - x * gR[5] - y * gR[6] + x * gR[7]);
  gq[1] = 2 * (y * gR[1] + z * gR[2] + y * gR[3] - 2 * x * gR[4] - w * gR[5] + z * gR[6] + w * gR[7] -
               2 * x * gR[8]);
  gq[2] = 2 * (-2 * y * gR[0] + x * gR[1] + w * gR[2] + x * gR[3] + z * gR[5] - w * gR[6] + z * gR[7] -
               2 * y * gR[8]);
  gq[3] = 2 * (-2 * z * gR[0] - w * gR[1] + x * gR[2] + w * gR[3] - 2 * z * gR[4] + y * gR[5] + x * gR[6] +
               y * gR[7]);
}

template <typename T>
void backward_one(const GaussianArrays<T>& g, uint32_t slot, const GaussianGeometry<T>& o,
                  const RenderCamera<T>& cam, const RasterConfig& cfg, const T* gs, size_t j,
                  GaussianGrads<T>& out) {
  const T* R = cam.R;
  const T x = o.pc[0], y = o.pc[1], z = o.pc[2];
  T gpc[3] = {0, 0, 0};
  T gmean[3] = {0, 0, 0};

  // Opacity logit (the splat's opacity is sigmoid * comp).
  out.opacity[j] = gs[kGOpacity] * o.comp * o.opacity * (1 - o.opacity);

  // Colour: SH coefficients and, through the viewing direction, the mean.
  const T graw[3] = {o.raw[0] > 0 ? gs[kGR] : T(0), o.raw[1] > 0 ? gs[kGG] : T(0),
                     o.raw[2] > 0 ? gs[kGB] : T(0)};
  const int nb = sh_coeffs_for_degree(cfg.sh_degree);
  T* gsh = out.sh.data() + size_t(kShFloats) * j;
  std::fill(gsh, gsh + kShFloats, T(0));
  for (int k = 0; k < nb; ++k)
    for (int c = 0; c < 3; ++c) gsh[3 * k + c] = graw[c] * o.basis[k];
  if (nb > 1) {
    T db[3 * kShCoeffs];
    sh::basis_gradient(cfg.sh_degree, o.dir[0], o.dir[1], o.dir[2], db);
    const T* shp = g.sh + size_t(kShFloats) * slot;
    T gdir[3] = {0, 0, 0};
    for (int k = 1; k < nb; ++k) {
      const T gk = graw[0] * shp[3 * k] + graw[1] * shp[3 * k + 1] + graw[2] * shp[3 * k + 2];
      for (int a = 0; a < 3; ++a) gdir[a] += gk * db[3 * k + a];
    }
    const T d = gdir[0] * o.dir[0] + gdir[1] * o.dir[1] + gdir[2] * o.dir[2];
    for (int a = 0; a < 3; ++a) gmean[a] += (gdir[a] - d * o.dir[a]) / o.dist;
  }

  // Conic -> 2D covariance: dL/dSigma2 = -K dL/dK K, with the off-diagonal gradient split in two.
  const T ka = o.C / o.det, kb = -o.B / o.det, kc = o.A / o.det;
  const T Ga = gs[kGCa], Gb = gs[kGCb] / 2, Gc = gs[kGCc];
  const T KG00 = ka * Ga + kb * Gb, KG01 = ka * Gb + kb * Gc, KG10 = kb * Ga + kc * Gb,
          KG11 = kb * Gb + kc * Gc;
  T gA = -(KG00 * ka + KG01 * kb), gB2 = -(KG00 * kb + KG01 * kc), gC = -(KG10 * kb + KG11 * kc);
  if (cfg.antialias) comp_backward(o, T(cfg.low_pass), gs[kGOpacity] * o.opacity, gA, gB2, gC);
  // G2 = [[gA, gB2], [gB2, gC]] is the symmetric gradient of Sigma2 = Tm Sigma Tm^T.
  const T G2[4] = {gA, gB2, gB2, gC};
  T G2T[6];  // G2 * Tm
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) G2T[3 * r + c] = G2[2 * r] * o.Tm[c] + G2[2 * r + 1] * o.Tm[3 + c];
  T gSigma[9];  // Tm^T G2 Tm
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) gSigma[3 * r + c] = o.Tm[r] * G2T[c] + o.Tm[3 + r] * G2T[3 + c];
  T gTm[6];  // 2 G2 Tm Sigma
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c)
      gTm[3 * r + c] =
          2 * (G2T[3 * r] * o.Sigma[c] + G2T[3 * r + 1] * o.Sigma[3 + c] + G2T[3 * r + 2] * o.Sigma[6 + c]);
  // Tm = J W: dL/dJ = dL/dTm W^T; J has four non-zero entries.
  auto dot_row = [&](const T* a, int row) {
    return a[0] * R[3 * row] + a[1] * R[3 * row + 1] + a[2] * R[3 * row + 2];
  };
  const T gJ00 = dot_row(gTm, 0), gJ02 = dot_row(gTm, 2), gJ11 = dot_row(gTm + 3, 1),
          gJ12 = dot_row(gTm + 3, 2);
  const T z2 = z * z;
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

  // Mean in pixels and depth.
  gpc[0] += gs[kGMx] * cam.fx / z;
  gpc[1] += gs[kGMy] * cam.fy / z;
  gpc[2] += -gs[kGMx] * cam.fx * x / z2 - gs[kGMy] * cam.fy * y / z2 + gs[kGZ];
  for (int a = 0; a < 3; ++a) gmean[a] += R[a] * gpc[0] + R[3 + a] * gpc[1] + R[6 + a] * gpc[2];
  for (int a = 0; a < 3; ++a) out.mean[3 * j + a] = gmean[a];

  // Sigma = M M^T with M = Rq diag(s): dL/dM = 2 gSigma M.
  T gRq[9];
  for (int c = 0; c < 3; ++c) {
    T gs_c = 0;
    for (int r = 0; r < 3; ++r) {
      T gM = 0;
      for (int k = 0; k < 3; ++k) gM += gSigma[3 * r + k] * o.Rq[3 * k + c];
      gM *= 2 * o.s[c];  // (2 gSigma Rq diag(s))_rc
      gs_c += gM * o.Rq[3 * r + c];
      gRq[3 * r + c] = gM * o.s[c];
    }
    out.log_scale[3 * j + c] = gs_c * o.s[c];
  }
  T gqn[4];
  quat_backward(o.qn, gRq, gqn);
  const T d = gqn[0] * o.qn[0] + gqn[1] * o.qn[1] + gqn[2] * o.qn[2] + gqn[3] * o.qn[3];
  for (int k = 0; k < 4; ++k) out.rotation[4 * j + k] = (gqn[k] - d * o.qn[k]) / o.qnorm;
}

}  // namespace

template <typename T>
void backward_splats(const GaussianArrays<T>& g, const uint32_t* ids, size_t n, const RenderCamera<T>& cam,
                     const RasterConfig& cfg, const std::vector<Splat<T>>& splats, const T* splat_grads,
                     GaussianGrads<T>& out) {
  out.resize(n);
#pragma omp parallel for schedule(static, 1024)
  for (long long jj = 0; jj < (long long)n; ++jj) {
    const size_t j = size_t(jj);
    GaussianGeometry<T> o;
    if (!splats[j].visible() || !compute_geometry(g, ids[j], cam, cfg, o)) {
      std::fill_n(out.mean.data() + 3 * j, 3, T(0));
      std::fill_n(out.log_scale.data() + 3 * j, 3, T(0));
      std::fill_n(out.rotation.data() + 4 * j, 4, T(0));
      out.opacity[j] = 0;
      std::fill_n(out.sh.data() + size_t(kShFloats) * j, kShFloats, T(0));
      continue;
    }
    backward_one(g, ids[j], o, cam, cfg, splat_grads + kSplatGrad * j, j, out);
  }
}

template void backward_splats<float>(const GaussianArrays<float>&, const uint32_t*, size_t,
                                     const RenderCamera<float>&, const RasterConfig&,
                                     const std::vector<Splat<float>>&, const float*, GaussianGrads<float>&);
template void backward_splats<double>(const GaussianArrays<double>&, const uint32_t*, size_t,
                                      const RenderCamera<double>&, const RasterConfig&,
                                      const std::vector<Splat<double>>&, const double*,
                                      GaussianGrads<double>&);

}  // namespace chungs::cpu
