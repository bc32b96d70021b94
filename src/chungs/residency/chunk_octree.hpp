// ChunkOctree: the chunks of a map (a sparse set of integer coordinates) grouped into an octree
// of aligned cubes, so the culler can accept or reject whole regions with one box test. Each node
// also keeps the tight bounding box of the chunks inside it, in world metres, computed with the
// same edge formula as a single chunk's box so that node and chunk tests agree bit for bit.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "chungs/store/chunk_id.hpp"

namespace chungs {

class ChunkOctree {
 public:
  struct Node {
    Eigen::Vector3d lo, hi;           // tight world box of the chunks below
    uint32_t begin = 0, end = 0;      // range in chunks()
    uint32_t first_child = 0;         // children are nodes [first_child, first_child + children)
    uint32_t children = 0;            // 0: a leaf
  };

  // Chunks per leaf at most (a leaf is also any node one chunk wide).
  static constexpr uint32_t kLeafChunks = 8;

  void build(std::vector<ChunkCoord> chunks, double chunk_size);  // duplicates are removed
  bool empty() const { return chunks_.empty(); }
  size_t size() const { return chunks_.size(); }
  double chunk_size() const { return chunk_size_; }
  const std::vector<ChunkCoord>& chunks() const { return chunks_; }  // grouped by node
  const std::vector<Node>& nodes() const { return nodes_; }          // nodes_[0] is the root

 private:
  void split(uint32_t node, ChunkCoord cube_lo, int64_t side);

  double chunk_size_ = 1.0;
  std::vector<ChunkCoord> chunks_;
  std::vector<Node> nodes_;
};

}  // namespace chungs
