#include "chungs/render/cpu/projection.hpp"

#include <cmath>

#include "chungs/render/cpu/gaussian_geometry.hpp"

namespace chungs::cpu {

namespace {

template <typename T>
Splat<T> make_splat(const GaussianGeometry<T>& o, const RenderCamera<T>& cam, const RasterConfig& cfg) {
  Splat<T> s;
  const T z = o.pc[2];
  s.mx = cam.fx * o.pc[0] / z + cam.cx;
  s.my = cam.fy * o.pc[1] / z + cam.cy;
  s.ca = o.C / o.det;
  s.cb = -o.B / o.det;
  s.cc = o.A / o.det;
  s.opacity = o.opacity * o.comp;
  s.z = z;
  s.inv_z = T(1) / z;
  for (int c = 0; c < 3; ++c) s.color[c] = std::max(o.raw[c], T(0));
  // A diverged Gaussian (NaN or infinite parameters) is not drawn rather than poisoning the image.
  if (!std::isfinite(s.mx) || !std::isfinite(s.my) || !std::isfinite(s.ca + s.cb + s.cc) ||
      !std::isfinite(s.opacity) || !std::isfinite(o.raw[0] + o.raw[1] + o.raw[2]))
    return Splat<T>{};
  const T mid = (o.A + o.C) / 2, half = (o.A - o.C) / 2;
  s.radius = 3 * std::sqrt(mid + std::sqrt(half * half + o.B * o.B));

  // The splat reaches a pixel while alpha >= min_alpha and q <= extent^2; both are one bound on the
  // exponent -q/2, and the footprint box is the bounding box of that ellipse.
  T pmin = T(-0.5 * cfg.extent_sigma * cfg.extent_sigma);
  if (cfg.min_alpha > 0) pmin = std::max(pmin, T(std::log(cfg.min_alpha)) - std::log(s.opacity));
  s.power_min = pmin;
  if (!(pmin < T(0))) return s;  // too faint to reach any pixel: empty box
  const T qmax = -2 * pmin;
  const T ex = std::sqrt(qmax * o.A), ey = std::sqrt(qmax * o.C);
  const T W1 = T(cam.width - 1), H1 = T(cam.height - 1);
  const T fx0 = std::ceil(s.mx - ex), fx1 = std::floor(s.mx + ex);
  const T fy0 = std::ceil(s.my - ey), fy1 = std::floor(s.my + ey);
  if (!(fx1 >= 0 && fx0 <= W1 && fy1 >= 0 && fy0 <= H1)) return s;  // outside the image (or NaN)
  s.x0 = int(std::max(fx0, T(0)));
  s.x1 = int(std::min(fx1, W1));
  s.y0 = int(std::max(fy0, T(0)));
  s.y1 = int(std::min(fy1, H1));
  return s;
}

}  // namespace

template <typename T>
void project_splats(const GaussianArrays<T>& g, const uint32_t* ids, size_t n, const RenderCamera<T>& cam,
                    const RasterConfig& cfg, std::vector<Splat<T>>& splats) {
  splats.resize(n);
#pragma omp parallel for schedule(static, 1024)
  for (long long j = 0; j < (long long)n; ++j) {
    GaussianGeometry<T> o;
    if (compute_geometry(g, ids[j], cam, cfg, o))
      splats[j] = make_splat(o, cam, cfg);
    else
      splats[j] = Splat<T>{};
  }
}

template void project_splats<float>(const GaussianArrays<float>&, const uint32_t*, size_t,
                                    const RenderCamera<float>&, const RasterConfig&,
                                    std::vector<Splat<float>>&);
template void project_splats<double>(const GaussianArrays<double>&, const uint32_t*, size_t,
                                     const RenderCamera<double>&, const RasterConfig&,
                                     std::vector<Splat<double>>&);

}  // namespace chungs::cpu
