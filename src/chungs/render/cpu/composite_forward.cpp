#include <algorithm>
#include <cmath>

#include "chungs/render/cpu/composite.hpp"

namespace chungs::cpu {

template <typename T>
void composite_forward(const std::vector<Splat<T>>& splats, const TileBins& bins, const uint32_t* ids,
                       const RasterConfig& cfg, RenderOutput<T>& out, std::vector<uint32_t>& last) {
  const int W = out.rgb.width(), H = out.rgb.height();
  last.assign(size_t(W) * size_t(H), 0);
  const T alpha_max = T(cfg.alpha_max), min_T = T(cfg.min_transmittance);
  const T bg[3] = {T(cfg.background[0]), T(cfg.background[1]), T(cfg.background[2])};
  const long long ntiles = (long long)bins.tiles();

#pragma omp parallel for schedule(dynamic, 1)
  for (long long tile = 0; tile < ntiles; ++tile) {
    const int tx = int(tile % bins.tiles_x), ty = int(tile / bins.tiles_x);
    const int px0 = tx * kTileSize, py0 = ty * kTileSize;
    const int px1 = std::min(px0 + kTileSize, W) - 1, py1 = std::min(py0 + kTileSize, H) - 1;
    const int tw = px1 - px0 + 1;
    const int npix = tw * (py1 - py0 + 1);

    // Per-pixel state of the tile: transmittance, accumulated r g b depth inv_depth, best weight.
    T Tr[kTileSize * kTileSize], acc[kTileSize * kTileSize][5], best_w[kTileSize * kTileSize];
    uint32_t best[kTileSize * kTileSize], cnt[kTileSize * kTileSize];
    bool done[kTileSize * kTileSize];
    for (int p = 0; p < npix; ++p) {
      Tr[p] = 1;
      for (int c = 0; c < 5; ++c) acc[p][c] = 0;
      best_w[p] = 0;
      best[p] = kNoGaussian;
      cnt[p] = 0;
      done[p] = false;
    }
    int active = npix;

    const size_t b = bins.start[tile], e = bins.start[tile + 1];
    for (size_t k = b; k < e && active > 0; ++k) {
      const uint32_t j = bins.list[k];
      const Splat<T>& s = splats[j];
      const int xs = std::max(s.x0, px0), xe = std::min(s.x1, px1);
      const int ys = std::max(s.y0, py0), ye = std::min(s.y1, py1);
      const T feat[5] = {s.color[0], s.color[1], s.color[2], s.z, s.inv_z};
      const uint32_t entry = uint32_t(k - b + 1);
      for (int y = ys; y <= ye; ++y) {
        const T dy = T(y) - s.my;
        const int row = (y - py0) * tw - px0;
        for (int x = xs; x <= xe; ++x) {
          const int p = row + x;
          if (done[p]) continue;
          const T dx = T(x) - s.mx;
          const T power = T(-0.5) * (s.ca * dx * dx + s.cc * dy * dy) - s.cb * dx * dy;
          if (power < s.power_min) continue;
          const T alpha = std::min(alpha_max, s.opacity * std::exp(power));
          const T nT = Tr[p] * (1 - alpha);
          if (nT < min_T) {
            done[p] = true;
            --active;
            continue;
          }
          const T w = alpha * Tr[p];
          for (int c = 0; c < 5; ++c) acc[p][c] += w * feat[c];
          if (w > best_w[p]) {
            best_w[p] = w;
            best[p] = j;
          }
          Tr[p] = nT;
          cnt[p] = entry;
        }
      }
    }

    for (int y = py0; y <= py1; ++y)
      for (int x = px0; x <= px1; ++x) {
        const int p = (y - py0) * tw + (x - px0);
        for (int c = 0; c < 3; ++c) out.rgb(x, y, c) = acc[p][c] + Tr[p] * bg[c];
        out.depth(x, y) = acc[p][3];
        out.inv_depth(x, y) = acc[p][4];
        out.alpha(x, y) = 1 - Tr[p];
        out.top_id(x, y) = best[p] == kNoGaussian ? kNoGaussian : ids[best[p]];
        last[size_t(y) * W + x] = cnt[p];
      }
  }
}

template void composite_forward<float>(const std::vector<Splat<float>>&, const TileBins&, const uint32_t*,
                                       const RasterConfig&, RenderOutput<float>&, std::vector<uint32_t>&);
template void composite_forward<double>(const std::vector<Splat<double>>&, const TileBins&, const uint32_t*,
                                        const RasterConfig&, RenderOutput<double>&, std::vector<uint32_t>&);

}  // namespace chungs::cpu
