// Which pixels of a keyframe a partial render can be scored on. Under a budget smaller than the
// selector's cell, a keyframe outside the training window is still trained, on the chunks of its view
// that are resident (nothing is loaded for it): a pixel counts when the surface it sees (its depth,
// or the sampler's fill depth where it has none) lies in a rendered chunk. Without such steps the
// views that saw a place best leave training with the window, and later views that see it at a
// grazing angle smear it (measured: -3 dB held-out on a 2 km street at a 100 k budget, whether or not
// chunks were evicted).
//
// ViewCoverage holds, per block of kBlock x kBlock pixels, the chunk its centre pixel sees, as an index
// into the view's list of such chunks: built once per keyframe, a mask costs one lookup per chunk and
// one write per pixel.
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/image/image.hpp"
#include "chungs/store/chunk_id.hpp"

namespace chungs {

class ViewCoverage {
 public:
  static constexpr int kBlock = 4;
  static constexpr uint16_t kNone = 0xFFFF;  // a block that sees no surface (no depth, no fill)

  ViewCoverage() = default;
  // depth: metres, 0 or non-finite where unknown (then fill_depth, if > 0); each block's surface in the
  // chunk `grid` gives it for this view (a distant cube's far level). Throws Error when the
  // depth map and the camera differ in size or the view sees more than 65 535 chunks.
  ViewCoverage(const ImageF& depth, const Camera& camera, const SE3& pose, const ChunkGrid& grid,
               double fill_depth);

  const std::vector<ChunkId>& chunks() const { return chunks_; }
  // Share of the blocks whose chunk satisfies `rendered` (0 when the view has no block).
  double coverage(const std::function<bool(ChunkId)>& rendered) const;
  // Full-resolution mask: 1 where the pixel's block sees a chunk that `rendered` accepts, else 0;
  // blocks that see no surface get `unseen` (a partial render cannot tell what they show; a whole
  // view trimmed of its farthest chunks still draws its sky there).
  Image8 mask(const std::function<bool(ChunkId)>& rendered, bool unseen = false) const;
  bool empty() const { return blocks_.empty(); }
  // Blocks per chunk, in the order of chunks().
  const std::vector<uint32_t>& blocks_per_chunk() const { return blocks_per_chunk_; }
  // The fewest chunks, those on the most blocks first, that together show at least `share` of the
  // blocks that see a chunk (ties: the earlier in chunks()); sorted.
  std::vector<ChunkId> core(double share) const;

 private:
  std::vector<bool> accepted(const std::function<bool(ChunkId)>& rendered) const;
  int width_ = 0, height_ = 0, bw_ = 0, bh_ = 0;
  std::vector<ChunkId> chunks_;
  std::vector<uint32_t> blocks_per_chunk_;
  std::vector<uint16_t> blocks_;  // bw_ x bh_, row-major
};

}  // namespace chungs
