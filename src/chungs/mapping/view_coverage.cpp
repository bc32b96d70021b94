#include "chungs/mapping/view_coverage.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "chungs/common/error.hpp"
#include "chungs/depth/guessed_depth.hpp"

namespace chungs {

ViewCoverage::ViewCoverage(const ImageF& depth, const Camera& camera, const SE3& pose, const ChunkGrid& grid,
                           double fill_depth)
    : width_(camera.width), height_(camera.height) {
  if (depth.width() != camera.width || depth.height() != camera.height)
    fail("view coverage: depth ", depth.width(), "x", depth.height(), " does not match the camera ",
         camera.width, "x", camera.height);
  bw_ = (width_ + kBlock - 1) / kBlock;
  bh_ = (height_ + kBlock - 1) / kBlock;
  blocks_.assign(size_t(bw_) * bh_, kNone);
  std::unordered_map<ChunkId, uint16_t> index;
  for (int by = 0; by < bh_; ++by)
    for (int bx = 0; bx < bw_; ++bx) {
      // The block's centre pixel, clamped into the image for a partial block at the border.
      const int x = std::min(bx * kBlock + kBlock / 2, width_ - 1),
                y = std::min(by * kBlock + kBlock / 2, height_ - 1);
      double z = placement_depth(depth(x, y));  // a guess still says where the surface is
      if (!(z > 0) || !std::isfinite(z)) z = fill_depth;
      if (!(z > 0)) continue;
      const ChunkId id = grid.for_view(pose * camera.unproject(Eigen::Vector2d(x, y), z), pose.t);
      auto [it, fresh] = index.try_emplace(id, uint16_t(chunks_.size()));
      if (fresh) {
        if (chunks_.size() >= kNone) fail("view coverage: the view sees more than ", kNone - 1, " chunks");
        chunks_.push_back(id);
        blocks_per_chunk_.push_back(0);
      }
      blocks_[size_t(by) * bw_ + bx] = it->second;
      ++blocks_per_chunk_[it->second];
    }
}

std::vector<bool> ViewCoverage::accepted(const std::function<bool(ChunkId)>& rendered) const {
  std::vector<bool> ok(chunks_.size());
  for (size_t i = 0; i < chunks_.size(); ++i) ok[i] = rendered(chunks_[i]);
  return ok;
}

std::vector<ChunkId> ViewCoverage::core(double share) const {
  const std::vector<uint32_t>& blocks = blocks_per_chunk_;
  std::vector<size_t> order(blocks.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return blocks[a] > blocks[b]; });
  const double total = std::accumulate(blocks.begin(), blocks.end(), 0.0);
  std::vector<ChunkId> out;
  double shown = 0;
  for (size_t i : order) {
    if (shown >= share * total) break;
    shown += blocks[i];
    out.push_back(chunks_[i]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

double ViewCoverage::coverage(const std::function<bool(ChunkId)>& rendered) const {
  if (blocks_.empty()) return 0;
  const std::vector<bool> ok = accepted(rendered);
  size_t n = 0;
  for (uint16_t b : blocks_) n += b != kNone && ok[b];
  return double(n) / double(blocks_.size());
}

Image8 ViewCoverage::mask(const std::function<bool(ChunkId)>& rendered, bool unseen) const {
  const std::vector<bool> ok = accepted(rendered);
  Image8 m(width_, height_, 1, 0);
  // One row of values per row of blocks, copied to the block's pixel rows: a mask at KITTI's size had
  // cost 0.5 ms of every partial or trimmed step when each pixel looked its block up.
  for (int by = 0; by < bh_; ++by) {
    const uint16_t* row = &blocks_[size_t(by) * bw_];
    const int y0 = by * kBlock, y1 = std::min(y0 + kBlock, height_);
    uint8_t* first = &m(0, y0);
    for (int bx = 0; bx < bw_; ++bx) {
      const uint16_t b = row[bx];
      const uint8_t v = b == kNone ? uint8_t(unseen) : uint8_t(ok[b]);
      const int x0 = bx * kBlock, x1 = std::min(x0 + kBlock, width_);
      std::fill(first + x0, first + x1, v);
    }
    for (int y = y0 + 1; y < y1; ++y) std::copy(first, first + width_, &m(0, y));
  }
  return m;
}

}  // namespace chungs
