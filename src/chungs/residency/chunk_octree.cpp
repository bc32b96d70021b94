#include "chungs/residency/chunk_octree.hpp"

#include <algorithm>

namespace chungs {

void ChunkOctree::build(std::vector<ChunkCoord> chunks, double chunk_size) {
  std::sort(chunks.begin(), chunks.end());
  chunks.erase(std::unique(chunks.begin(), chunks.end()), chunks.end());
  chunks_ = std::move(chunks);
  chunk_size_ = chunk_size;
  nodes_.clear();
  if (chunks_.empty()) return;
  ChunkCoord lo = chunks_[0], hi = chunks_[0];
  for (const auto& c : chunks_) {
    lo = {std::min(lo.x, c.x), std::min(lo.y, c.y), std::min(lo.z, c.z)};
    hi = {std::max(hi.x, c.x), std::max(hi.y, c.y), std::max(hi.z, c.z)};
  }
  const int64_t extent = std::max({int64_t(hi.x) - lo.x, int64_t(hi.y) - lo.y, int64_t(hi.z) - lo.z}) + 1;
  int64_t side = 1;
  while (side < extent) side *= 2;
  nodes_.push_back({});
  nodes_[0].begin = 0;
  nodes_[0].end = uint32_t(chunks_.size());
  split(0, lo, side);
}

void ChunkOctree::split(uint32_t index, ChunkCoord cube_lo, int64_t side) {
  const uint32_t b = nodes_[index].begin, e = nodes_[index].end;
  ChunkCoord lo = chunks_[b], hi = chunks_[b];
  for (uint32_t i = b; i < e; ++i) {
    const ChunkCoord& c = chunks_[i];
    lo = {std::min(lo.x, c.x), std::min(lo.y, c.y), std::min(lo.z, c.z)};
    hi = {std::max(hi.x, c.x), std::max(hi.y, c.y), std::max(hi.z, c.z)};
  }
  chunk_box(lo, hi, chunk_size_, nodes_[index].lo, nodes_[index].hi);
  if (e - b <= kLeafChunks || side == 1) return;

  // Sort the range into octants: split on x, then each half on y, then each quarter on z.
  const int64_t half = side / 2;
  const int64_t mid[3] = {cube_lo.x + half, cube_lo.y + half, cube_lo.z + half};
  auto first = chunks_.begin() + b, last = chunks_.begin() + e;
  auto px = std::partition(first, last, [&](const ChunkCoord& c) { return c.x < mid[0]; });
  std::vector<decltype(first)> bounds{first};
  for (auto [f, l] : {std::pair{first, px}, std::pair{px, last}}) {
    auto py = std::partition(f, l, [&](const ChunkCoord& c) { return c.y < mid[1]; });
    for (auto [f2, l2] : {std::pair{f, py}, std::pair{py, l}}) {
      auto pz = std::partition(f2, l2, [&](const ChunkCoord& c) { return c.z < mid[2]; });
      bounds.push_back(pz);
      bounds.push_back(l2);
    }
  }
  // bounds: first, then for each octant its split point and end; octant k spans [start_k, end_k).
  struct Part {
    uint32_t begin, end;
    ChunkCoord lo;
  };
  std::vector<Part> parts;
  auto start = first;
  for (int k = 0; k < 8; ++k) {
    const auto stop = bounds[1 + k];
    const ChunkCoord octant_lo{int32_t(cube_lo.x + ((k >> 2) & 1) * half), int32_t(cube_lo.y + ((k >> 1) & 1) * half),
                               int32_t(cube_lo.z + (k & 1) * half)};
    if (stop != start)
      parts.push_back({uint32_t(start - chunks_.begin()), uint32_t(stop - chunks_.begin()), octant_lo});
    start = stop;
  }
  const uint32_t first_child = uint32_t(nodes_.size());
  nodes_[index].first_child = first_child;
  nodes_[index].children = uint32_t(parts.size());
  for (const Part& p : parts) {
    Node n;
    n.begin = p.begin;
    n.end = p.end;
    nodes_.push_back(n);
  }
  for (size_t k = 0; k < parts.size(); ++k) split(first_child + uint32_t(k), parts[k].lo, half);
}

}  // namespace chungs
