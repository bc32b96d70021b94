// Backward of front-to-back compositing, walked front to back again: with C the final value of a
// channel, C_i the part composited up to and including splat i, and T_i the transmittance in front of
// it, dC/dalpha_i = c_i T_i - (C - C_i) / (1 - alpha_i). The final values come from the forward
// outputs, so nothing per pixel-splat pair is stored.
#include <omp.h>

#include <algorithm>
#include <cmath>

#include "chungs/render/cpu/composite.hpp"
#include "chungs/render/cpu/lanes.hpp"

namespace chungs::cpu {

template <typename T>
void composite_backward(const std::vector<Splat<T>>& splats, const TileBins& bins, const RasterConfig& cfg,
                        const RenderOutput<T>& out, const std::vector<uint32_t>& last,
                        const RenderGrads<T>& grads, std::vector<std::vector<T>>& thread_buffers,
                        std::vector<T>& splat_grads) {
  const int W = out.rgb.width(), H = out.rgb.height();
  const size_t n = splats.size();
  using L = Lanes<T>;
  using V = typename L::V;
  using M = typename L::M;
  using I = typename L::I;
  constexpr int N = L::N;
  const V alpha_max = L::splat(T(cfg.alpha_max));
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

      // Per pixel (16 x 16, zero past the image border): transmittance, composited r g b depth
      // inv_depth so far, their final values, dL/d(final) of each, the alpha term
      // T_final * dL/dalpha, and how many entries to walk.
      constexpr int P = kTileSize * kTileSize;
      alignas(64) T Tr[P], acc[5][P], fin[5][P], g[5][P], galpha_Tf[P];
      alignas(64) I stop[P];
      for (int p = 0; p < P; ++p) {
        Tr[p] = 1;
        galpha_Tf[p] = 0;
        stop[p] = 0;
        for (int c = 0; c < 5; ++c) acc[c][p] = fin[c][p] = g[c][p] = 0;
      }
      I max_stop = 0;
      I row_stop[kTileSize] = {};  // entries to walk for the longest pixel of each tile row
      for (int y = py0; y <= py1; ++y)
        for (int x = px0; x <= px1; ++x) {
          const int p = (y - py0) * kTileSize + (x - px0);
          for (int c = 0; c < 3; ++c) {
            fin[c][p] = out.rgb(x, y, c);
            g[c][p] = grad_at(grads.rgb, x, y, c);
          }
          fin[3][p] = out.depth(x, y);
          fin[4][p] = out.inv_depth(x, y);
          g[3][p] = grad_at(grads.depth, x, y, 0);
          g[4][p] = grad_at(grads.inv_depth, x, y, 0);
          galpha_Tf[p] = grad_at(grads.alpha, x, y, 0) * (1 - out.alpha(x, y));
          stop[p] = I(last[size_t(y) * W + x]);
          max_stop = std::max(max_stop, stop[p]);
          row_stop[y - py0] = std::max(row_stop[y - py0], stop[p]);
        }

      const size_t b = bins.start[tile];
      for (I e = 0; e < max_stop; ++e) {
        const uint32_t j = bins.list[b + size_t(e)];
        const Splat<T>& s = splats[j];
        if (e + 2 < max_stop) __builtin_prefetch(&splats[bins.list[b + size_t(e) + 2]]);
        const int xs = std::max(s.x0, px0), xe = std::min(s.x1, px1);
        const int ys = std::max(s.y0, py0), ye = std::min(s.y1, py1);
        const T feat[5] = {s.color[0], s.color[1], s.color[2], s.z, s.inv_z};
        const T inv_z2 = s.inv_z * s.inv_z;
        const V pmin = L::splat(s.power_min), opacity = L::splat(s.opacity);
        const M ev = L::splat_i(e);
        V gmx{}, gmy{}, gca{}, gcb{}, gcc{}, gop{}, gc0{}, gc1{}, gc2{}, gz{};
        bool touched = false;
        for (int y = ys; y <= ye; ++y) {
          if (e >= row_stop[y - py0]) continue;
          const T dy = T(y) - s.my;
          int rx0, rx1;
          if (!s.row_span(dy, xs, xe, rx0, rx1)) continue;
          touched = true;
          const T cdy2 = s.cc * dy * dy, bdy = s.cb * dy;
          const V lo = L::splat(T(rx0 - px0)), hi = L::splat(T(rx1 - px0));
          for (int q = (rx0 - px0) / N; q <= (rx1 - px0) / N; ++q) {
            const int off = (y - py0) * kTileSize + q * N;
            const V lx = L::iota() + T(q * N);
            const V dx = lx + (T(px0) - s.mx);
            const V power = T(-0.5) * (s.ca * dx * dx + cdy2) - bdy * dx;
            const M live = (lx >= lo) & (lx <= hi) & (power >= pmin) & (ev < L::load_i(stop + off));
            if (!L::any(live)) continue;
            const V G = L::exp(power);
            const V raw = opacity * G;
            const M clamped = raw > alpha_max;
            const V alpha = live ? (clamped ? alpha_max : raw) : V{};  // 0 leaves masked lanes as they are
            const V Ti = L::load(Tr + off);
            const V w = alpha * Ti;
            const V inv_1ma = 1 / (1 - alpha);
            V dalpha = L::load(galpha_Tf + off) * inv_1ma;
            V gch[5];
            for (int c = 0; c < 5; ++c) {
              const V a = L::load(acc[c] + off) + w * feat[c];
              L::store(acc[c] + off, a);
              gch[c] = L::load(g[c] + off);
              dalpha += gch[c] * (feat[c] * Ti - (L::load(fin[c] + off) - a) * inv_1ma);
            }
            gc0 += w * gch[0], gc1 += w * gch[1], gc2 += w * gch[2];
            gz += w * (gch[3] - gch[4] * inv_z2);
            L::store(Tr + off, Ti * (1 - alpha));
            const V dal = (live & ~clamped) ? dalpha : V{};
            gop += dal * G;
            const V gpow = dal * alpha;
            gmx += gpow * (s.ca * dx + s.cb * dy);
            gmy += gpow * (s.cb * dx + s.cc * dy);
            gca += gpow * (T(-0.5) * dx * dx);
            gcb -= gpow * (dx * dy);
            gcc += gpow * (T(-0.5) * dy * dy);
          }
        }
        if (!touched) continue;
        T* d = buf.data() + size_t(j) * kSplatGrad;
        d[kGMx] += L::sum(gmx), d[kGMy] += L::sum(gmy), d[kGCa] += L::sum(gca), d[kGCb] += L::sum(gcb);
        d[kGCc] += L::sum(gcc), d[kGOpacity] += L::sum(gop), d[kGR] += L::sum(gc0), d[kGG] += L::sum(gc1);
        d[kGB] += L::sum(gc2), d[kGZ] += L::sum(gz);
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

template void composite_backward<float>(const std::vector<Splat<float>>&, const TileBins&,
                                        const RasterConfig&, const RenderOutput<float>&,
                                        const std::vector<uint32_t>&, const RenderGrads<float>&,
                                        std::vector<std::vector<float>>&, std::vector<float>&);
template void composite_backward<double>(const std::vector<Splat<double>>&, const TileBins&,
                                         const RasterConfig&, const RenderOutput<double>&,
                                         const std::vector<uint32_t>&, const RenderGrads<double>&,
                                         std::vector<std::vector<double>>&, std::vector<double>&);

}  // namespace chungs::cpu
