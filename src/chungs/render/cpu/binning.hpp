// Tile binning: every visible splat is listed in each 16x16 tile its footprint box touches, and each
// tile's list is in front-to-back order of the splats' view-space depth (ties by index).
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "chungs/render/cpu/splat.hpp"
#include "chungs/render/raster_config.hpp"

namespace chungs::cpu {

struct TileRect {
  uint16_t tx0, tx1, ty0, ty1;  // inclusive tile range
};

struct TileBins {
  int tiles_x = 0, tiles_y = 0;
  std::vector<size_t> start;   // tiles_x * tiles_y + 1 offsets into `list`
  std::vector<uint32_t> list;  // splat indices
  // Scratch kept between calls to avoid reallocation.
  std::vector<uint32_t> keys, order, tmp_keys, tmp_order, rank_to_splat;
  std::vector<TileRect> rects;
  std::vector<size_t> counts;

  size_t tiles() const { return size_t(tiles_x) * size_t(tiles_y); }
};

template <typename T>
void bin_splats(const std::vector<Splat<T>>& splats, int width, int height, TileBins& bins);

}  // namespace chungs::cpu
