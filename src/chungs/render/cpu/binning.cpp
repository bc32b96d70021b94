#include "chungs/render/cpu/binning.hpp"

#include <omp.h>

#include <algorithm>
#include <cstring>

#include "chungs/common/error.hpp"

namespace chungs::cpu {

namespace {

// Stable LSD radix sort of (key, value) pairs on the 32-bit key, 8 bits a pass; passes whose byte is
// the same for every key are skipped (the top byte of nearby float depths usually is).
void radix_sort(std::vector<uint32_t>& keys, std::vector<uint32_t>& vals, std::vector<uint32_t>& tk,
                std::vector<uint32_t>& tv) {
  const size_t n = keys.size();
  tk.resize(n);
  tv.resize(n);
  for (int shift = 0; shift < 32; shift += 8) {
    size_t count[257] = {};
    for (size_t i = 0; i < n; ++i) ++count[((keys[i] >> shift) & 0xFF) + 1];
    bool single = false;
    for (int b = 1; b <= 256; ++b)
      if (count[b] == n) single = true;
    if (single) continue;
    for (int b = 0; b < 256; ++b) count[b + 1] += count[b];
    for (size_t i = 0; i < n; ++i) {
      const size_t dst = count[(keys[i] >> shift) & 0xFF]++;
      tk[dst] = keys[i];
      tv[dst] = vals[i];
    }
    keys.swap(tk);
    vals.swap(tv);
  }
}

}  // namespace

template <typename T>
void bin_splats(const std::vector<Splat<T>>& splats, int width, int height, TileBins& bins) {
  bins.tiles_x = (width + kTileSize - 1) / kTileSize;
  bins.tiles_y = (height + kTileSize - 1) / kTileSize;
  const size_t ntiles = bins.tiles();
  if (bins.tiles_x > 65535 || bins.tiles_y > 65535)
    fail("rasterizer: image ", width, "x", height, " has more than 65535 tiles along a side");

  // Depth order of the visible splats. z >= near > 0, so the float bit pattern orders like the value.
  // The tile rectangles go to a compact array in the same pass, so the passes below that walk the
  // splats in depth order (random access) touch 8 bytes per splat instead of a whole Splat.
  bins.keys.clear();
  bins.order.clear();
  bins.rects.clear();
  for (size_t j = 0; j < splats.size(); ++j) {
    const Splat<T>& s = splats[j];
    if (!s.visible()) continue;
    const float zf = float(s.z);
    uint32_t key;
    std::memcpy(&key, &zf, sizeof key);
    bins.keys.push_back(key);
    bins.order.push_back(uint32_t(j));
    bins.rects.push_back({uint16_t(s.x0 / kTileSize), uint16_t(s.x1 / kTileSize), uint16_t(s.y0 / kTileSize),
                          uint16_t(s.y1 / kTileSize)});
  }
  // order[] now maps to rects[] by visible rank; sort the ranks, then translate to splat indices.
  bins.rank_to_splat = bins.order;
  for (size_t r = 0; r < bins.order.size(); ++r) bins.order[r] = uint32_t(r);
  radix_sort(bins.keys, bins.order, bins.tmp_keys, bins.tmp_order);
  const size_t nvis = bins.order.size();

  // Parallel stable counting sort by tile: each thread takes a contiguous piece of the depth order,
  // counts its entries per tile, and writes them after the pieces of the threads before it.
  const int nthreads = std::max(1, std::min<int>(omp_get_max_threads(), int(nvis / 4096) + 1));
  bins.counts.assign(size_t(nthreads) * ntiles, 0);
  auto tile_box = [&](uint32_t rank, int& tx0, int& tx1, int& ty0, int& ty1) {
    const TileRect& r = bins.rects[rank];
    tx0 = r.tx0, tx1 = r.tx1, ty0 = r.ty0, ty1 = r.ty1;
  };
#pragma omp parallel num_threads(nthreads)
  {
    const int t = omp_get_thread_num(), team = omp_get_num_threads();  // team may be below nthreads
    const size_t b = nvis * t / team, e = nvis * (t + 1) / team;
    size_t* cnt = bins.counts.data() + size_t(t) * ntiles;
    for (size_t k = b; k < e; ++k) {
      int tx0, tx1, ty0, ty1;
      tile_box(bins.order[k], tx0, tx1, ty0, ty1);
      for (int ty = ty0; ty <= ty1; ++ty)
        for (int tx = tx0; tx <= tx1; ++tx) ++cnt[size_t(ty) * bins.tiles_x + tx];
    }
#pragma omp barrier
#pragma omp single
    {
      bins.start.assign(ntiles + 1, 0);
      size_t total = 0;
      for (size_t tile = 0; tile < ntiles; ++tile) {
        bins.start[tile] = total;
        for (int p = 0; p < team; ++p) {
          size_t& c = bins.counts[size_t(p) * ntiles + tile];
          const size_t n = c;
          c = total;  // becomes this thread's write cursor for the tile
          total += n;
        }
      }
      bins.start[ntiles] = total;
      bins.list.resize(total);
    }
    for (size_t k = b; k < e; ++k) {
      const uint32_t rank = bins.order[k], j = bins.rank_to_splat[rank];
      int tx0, tx1, ty0, ty1;
      tile_box(rank, tx0, tx1, ty0, ty1);
      for (int ty = ty0; ty <= ty1; ++ty)
        for (int tx = tx0; tx <= tx1; ++tx) bins.list[cnt[size_t(ty) * bins.tiles_x + tx]++] = j;
    }
  }
}

template void bin_splats<float>(const std::vector<Splat<float>>&, int, int, TileBins&);
template void bin_splats<double>(const std::vector<Splat<double>>&, int, int, TileBins&);

}  // namespace chungs::cpu
