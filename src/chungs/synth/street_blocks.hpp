// StreetBlocks: the city blocks of a street world generated so far, for every world (renderer) that
// shares it. A block is generated once for all of them, and memory holds one cache, full a few
// hundred metres into a drive. With a cache per renderer, the dataset's renderers (one per thread
// that renders at the same time) each filled their own, a rarely used one only as it happened to be
// used: over the whole 10 km drive, host memory still rising minutes after the map's budget was
// full (bench/README.md).
//
// Least recently used blocks beyond StreetOptions::max_blocks are dropped; a world keeps the
// meshes of its latest view alive itself, so dropping one another world still draws is harmless.
// Blocks are a pure function of (seed, block index): which thread generates one does not matter.
// Thread-safe; a block is generated outside the lock (two threads may both build one; one is kept).
#pragma once
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_map>

#include "chungs/synth/mesh.hpp"

namespace chungs::synth {

struct StreetOptions;

class StreetBlocks {
 public:
  explicit StreetBlocks(const StreetOptions& opt);
  ~StreetBlocks();

  // Block (bx, by): from the cache, or generated now.
  std::shared_ptr<const Mesh> get(int bx, int by);

  size_t in_memory() const;
  size_t generated() const;           // including regenerations
  size_t distinct() const;            // blocks ever touched
  size_t distinct_triangles() const;  // over those
  size_t triangles() const;           // of the blocks in memory

 private:
  struct Entry {
    std::shared_ptr<const Mesh> mesh;
    uint64_t last_used = 0;
  };
  static int64_t key(int bx, int by) { return (int64_t(bx) << 32) ^ int64_t(uint32_t(by)); }
  void evict_locked();

  std::unique_ptr<const StreetOptions> opt_;
  mutable std::mutex mutex_;
  std::unordered_map<int64_t, Entry> cache_;
  std::unordered_map<int64_t, size_t> distinct_;  // block -> triangles
  uint64_t clock_ = 0;                            // one tick per get()
  size_t generated_ = 0;
};

}  // namespace chungs::synth
