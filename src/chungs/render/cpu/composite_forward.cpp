#include <algorithm>
#include <cmath>

#include "chungs/render/cpu/composite.hpp"
#include "chungs/render/cpu/lanes.hpp"

namespace chungs::cpu {

template <typename T>
void composite_forward(const std::vector<Splat<T>>& splats, const TileBins& bins, const uint32_t* ids,
                       const RasterConfig& cfg, RenderOutput<T>& out, std::vector<uint32_t>& last) {
  using L = Lanes<T>;
  using V = typename L::V;
  using M = typename L::M;
  using I = typename L::I;
  constexpr int N = L::N;
  const int W = out.rgb.width(), H = out.rgb.height();
  last.assign(size_t(W) * size_t(H), 0);
  const V alpha_max = L::splat(T(cfg.alpha_max)), min_T = L::splat(T(cfg.min_transmittance));
  const T bg[3] = {T(cfg.background[0]), T(cfg.background[1]), T(cfg.background[2])};
  const long long ntiles = (long long)bins.tiles();

#pragma omp parallel for schedule(dynamic, 1)
  for (long long tile = 0; tile < ntiles; ++tile) {
    const int tx = int(tile % bins.tiles_x), ty = int(tile / bins.tiles_x);
    const int px0 = tx * kTileSize, py0 = ty * kTileSize;
    const int px1 = std::min(px0 + kTileSize, W) - 1, py1 = std::min(py0 + kTileSize, H) - 1;
    int active = (px1 - px0 + 1) * (py1 - py0 + 1);
    int row_active[kTileSize] = {};  // pixels of each tile row still compositing
    for (int y = py0; y <= py1; ++y) row_active[y - py0] = px1 - px0 + 1;

    // Per-pixel state of the tile, 16 x 16 also past the image border (those lanes are never live):
    // transmittance, accumulated r g b depth inv_depth, largest weight and its splat (-1: none),
    // entries walked up to the last contribution, stopped flag (-1 = stopped).
    constexpr int P = kTileSize * kTileSize;
    alignas(64) T Tr[P], acc[5][P], best_w[P];
    alignas(64) I best[P], cnt[P], done[P];
    for (int p = 0; p < P; ++p) {
      Tr[p] = 1;
      for (int c = 0; c < 5; ++c) acc[c][p] = 0;
      best_w[p] = 0;
      best[p] = -1;
      cnt[p] = 0;
      done[p] = 0;
    }

    const size_t b = bins.start[tile], e = bins.start[tile + 1];
    for (size_t k = b; k < e && active > 0; ++k) {
      const uint32_t j = bins.list[k];
      const Splat<T>& s = splats[j];
      if (k + 2 < e) __builtin_prefetch(&splats[bins.list[k + 2]]);  // random access: hide the miss
      const int xs = std::max(s.x0, px0), xe = std::min(s.x1, px1);
      const int ys = std::max(s.y0, py0), ye = std::min(s.y1, py1);
      const T feat[5] = {s.color[0], s.color[1], s.color[2], s.z, s.inv_z};
      const M entry = L::splat_i(I(k - b + 1)), jv = L::splat_i(I(j));
      const V pmin = L::splat(s.power_min), opacity = L::splat(s.opacity);
      for (int y = ys; y <= ye; ++y) {
        if (row_active[y - py0] == 0) continue;
        const T dy = T(y) - s.my;
        int rx0, rx1;
        if (!s.row_span(dy, xs, xe, rx0, rx1)) continue;
        const T cdy2 = s.cc * dy * dy, bdy = s.cb * dy;
        const V lo = L::splat(T(rx0 - px0)), hi = L::splat(T(rx1 - px0));
        // Groups of N pixels of the row that overlap the span; masks decide what each lane writes.
        for (int q = (rx0 - px0) / N; q <= (rx1 - px0) / N; ++q) {
          const int off = (y - py0) * kTileSize + q * N;
          const V lx = L::iota() + T(q * N);
          const V dx = lx + (T(px0) - s.mx);
          const V power = T(-0.5) * (s.ca * dx * dx + cdy2) - bdy * dx;
          const M done_v = L::load_i(done + off);
          const M live = (lx >= lo) & (lx <= hi) & (power >= pmin) & (done_v == 0);
          if (!L::any(live)) continue;
          const V alpha = L::min(alpha_max, opacity * L::exp(power));
          const V Ti = L::load(Tr + off);
          const V nT = Ti * (1 - alpha);
          const M stop = live & (nT < min_T);  // this splat would take T below the cut-off
          const M use = live & ~stop;
          const V w = use ? alpha * Ti : V{};
          for (int c = 0; c < 5; ++c) L::store(acc[c] + off, L::load(acc[c] + off) + w * feat[c]);
          L::store(Tr + off, use ? nT : Ti);
          L::store_i(done + off, done_v | stop);
          int stopped = 0;
          for (int i = 0; i < N; ++i) stopped += stop[i] != 0;
          active -= stopped;
          row_active[y - py0] -= stopped;
          const V bw = L::load(best_w + off);
          const M better = w > bw;
          L::store(best_w + off, better ? w : bw);
          L::store_i(best + off, better ? jv : L::load_i(best + off));
          L::store_i(cnt + off, use ? entry : L::load_i(cnt + off));
        }
      }
    }

    for (int y = py0; y <= py1; ++y)
      for (int x = px0; x <= px1; ++x) {
        const int p = (y - py0) * kTileSize + (x - px0);
        for (int c = 0; c < 3; ++c) out.rgb(x, y, c) = acc[c][p] + Tr[p] * bg[c];
        out.depth(x, y) = acc[3][p];
        out.inv_depth(x, y) = acc[4][p];
        out.alpha(x, y) = 1 - Tr[p];
        out.top_id(x, y) = best[p] < 0 ? kNoGaussian : ids[best[p]];
        last[size_t(y) * W + x] = uint32_t(cnt[p]);
      }
  }
}

template void composite_forward<float>(const std::vector<Splat<float>>&, const TileBins&, const uint32_t*,
                                       const RasterConfig&, RenderOutput<float>&, std::vector<uint32_t>&);
template void composite_forward<double>(const std::vector<Splat<double>>&, const TileBins&, const uint32_t*,
                                        const RasterConfig&, RenderOutput<double>&, std::vector<uint32_t>&);

}  // namespace chungs::cpu
