// Backward of front-to-back compositing, walked front to back again: with C the final value of a
// channel, C_i the part composited up to and including splat i, and T_i the transmittance in front of
// it, dC/dalpha_i = c_i T_i - (C - C_i) / (1 - alpha_i). The final values come from the forward
// outputs, so nothing per pixel-splat pair is stored.
#include <omp.h>

#include <algorithm>
#include <cmath>

#include "chungs/render/cpu/composite.hpp"

namespace chungs::cpu {

template <typename T>
void composite_backward(const std::vector<Splat<T>>& splats, const TileBins& bins, const RasterConfig& cfg,
                        const RenderOutput<T>& out, const std::vector<uint32_t>& last,
                        const RenderGrads<T>& grads, std::vector<std::vector<T>>& thread_buffers,
                        std::vector<T>& splat_grads) {
  const int W = out.rgb.width(), H = out.rgb.height();
  const size_t n = splats.size();
  const T alpha_max = T(cfg.alpha_max);
  const long long ntiles = (long long)bins.tiles();
  const int nthreads = omp_get_max_threads();
  thread_buffers.resize(size_t(nthreads));
  splat_grads.resize(n * kSplatGrad);

  auto grad_at = [](const Image<T>& img, int x, int y, int c) { return img.empty() ? T(0) : img(x, y, c); };

#pragma omp parallel num_threads(nthreads)
  {
    const int team = omp_get_num_threads();  // may be fewer than asked for
    std::vector<T>& buf = thread_buffers[size_t(omp_get_thread_num())];
    buf.assign(n * kSplatGrad, T(0));

#pragma omp for schedule(dynamic, 1)
    for (long long tile = 0; tile < ntiles; ++tile) {
      const int tx = int(tile % bins.tiles_x), ty = int(tile / bins.tiles_x);
      const int px0 = tx * kTileSize, py0 = ty * kTileSize;
      const int px1 = std::min(px0 + kTileSize, W) - 1, py1 = std::min(py0 + kTileSize, H) - 1;
      const int tw = px1 - px0 + 1;

      // Per pixel: transmittance, composited r g b depth inv_depth so far, final values, dL/d(final)
      // for r g b depth inv_depth and the alpha term T_final * dL/dalpha, and how far to walk.
      constexpr int P = kTileSize * kTileSize;
      T Tr[P], acc[P][5], fin[P][5], g[P][5], galpha_Tf[P];
      uint32_t stop[P];
      uint32_t max_stop = 0;
      for (int y = py0; y <= py1; ++y)
        for (int x = px0; x <= px1; ++x) {
          const int p = (y - py0) * tw + (x - px0);
          Tr[p] = 1;
          for (int c = 0; c < 3; ++c) {
            fin[p][c] = out.rgb(x, y, c);
            g[p][c] = grad_at(grads.rgb, x, y, c);
          }
          fin[p][3] = out.depth(x, y);
          fin[p][4] = out.inv_depth(x, y);
          g[p][3] = grad_at(grads.depth, x, y, 0);
          g[p][4] = grad_at(grads.inv_depth, x, y, 0);
          galpha_Tf[p] = grad_at(grads.alpha, x, y, 0) * (1 - out.alpha(x, y));
          for (int c = 0; c < 5; ++c) acc[p][c] = 0;
          stop[p] = last[size_t(y) * W + x];
          max_stop = std::max(max_stop, stop[p]);
        }

      const size_t b = bins.start[tile];
      for (uint32_t e = 0; e < max_stop; ++e) {
        const uint32_t j = bins.list[b + e];
        const Splat<T>& s = splats[j];
        const int xs = std::max(s.x0, px0), xe = std::min(s.x1, px1);
        const int ys = std::max(s.y0, py0), ye = std::min(s.y1, py1);
        const T feat[5] = {s.color[0], s.color[1], s.color[2], s.z, s.inv_z};
        T gmx = 0, gmy = 0, gca = 0, gcb = 0, gcc = 0, gop = 0, gcol[3] = {0, 0, 0}, gz = 0;
        bool touched = false;
        for (int y = ys; y <= ye; ++y) {
          const T dy = T(y) - s.my;
          const int row = (y - py0) * tw - px0;
          for (int x = xs; x <= xe; ++x) {
            const int p = row + x;
            if (e >= stop[p]) continue;
            const T dx = T(x) - s.mx;
            const T power = T(-0.5) * (s.ca * dx * dx + s.cc * dy * dy) - s.cb * dx * dy;
            if (power < s.power_min) continue;
            const T G = std::exp(power);
            const T raw = s.opacity * G;
            const bool clamped = raw > alpha_max;
            const T alpha = clamped ? alpha_max : raw;
            const T Ti = Tr[p];
            const T w = alpha * Ti;
            const T inv_1ma = 1 / (1 - alpha);
            T dalpha = galpha_Tf[p] * inv_1ma;
            for (int c = 0; c < 5; ++c) {
              acc[p][c] += w * feat[c];
              dalpha += g[p][c] * (feat[c] * Ti - (fin[p][c] - acc[p][c]) * inv_1ma);
            }
            for (int c = 0; c < 3; ++c) gcol[c] += w * g[p][c];
            gz += w * (g[p][3] - g[p][4] * s.inv_z * s.inv_z);
            Tr[p] = Ti * (1 - alpha);
            touched = true;
            if (clamped) continue;
            gop += dalpha * G;
            const T gpow = dalpha * alpha;
            gmx += gpow * (s.ca * dx + s.cb * dy);
            gmy += gpow * (s.cb * dx + s.cc * dy);
            gca += gpow * T(-0.5) * dx * dx;
            gcb += -gpow * dx * dy;
            gcc += gpow * T(-0.5) * dy * dy;
          }
        }
        if (!touched) continue;
        T* d = buf.data() + size_t(j) * kSplatGrad;
        d[kGMx] += gmx, d[kGMy] += gmy, d[kGCa] += gca, d[kGCb] += gcb, d[kGCc] += gcc;
        d[kGOpacity] += gop, d[kGR] += gcol[0], d[kGG] += gcol[1], d[kGB] += gcol[2], d[kGZ] += gz;
      }
    }

    // Sum the per-thread buffers (the implicit barrier of the loop above has passed).
#pragma omp for schedule(static)
    for (long long i = 0; i < (long long)(n * kSplatGrad); ++i) {
      T sum = 0;
      for (int t = 0; t < team; ++t) sum += thread_buffers[size_t(t)][size_t(i)];
      splat_grads[size_t(i)] = sum;
    }
  }
}

template void composite_backward<float>(const std::vector<Splat<float>>&, const TileBins&, const RasterConfig&,
                                        const RenderOutput<float>&, const std::vector<uint32_t>&,
                                        const RenderGrads<float>&, std::vector<std::vector<float>>&,
                                        std::vector<float>&);
template void composite_backward<double>(const std::vector<Splat<double>>&, const TileBins&,
                                         const RasterConfig&, const RenderOutput<double>&,
                                         const std::vector<uint32_t>&, const RenderGrads<double>&,
                                         std::vector<std::vector<double>>&, std::vector<double>&);

}  // namespace chungs::cpu
