// HostBlockPool: host memory for chunks in flight between Residency and the disk (read-ahead,
// queued writes, checkpoint copies), mapped once when Residency is made and carved into blocks.
//
// Those chunks come and go in sizes that never repeat, on several threads, while the map's own
// data grows slowly beside them. From the general heap each new high of the queues took new heap,
// and what the map allocated meanwhile filled the holes they left, so host RSS kept stepping up
// long after the budget was reached (bench/README.md, the 10 km drive). Here their memory is one
// fixed region, used by nothing else: it never grows, and make_resident() makes all of it resident
// at the start, so RSS does not move when the queues fill.
//
// A block is one chunk's 19 arrays (gaussians/block_arrays.hpp) laid out back to back in a free
// range of the region (best fit, ranges merged again when freed). When no range fits, make() takes
// the block from the heap instead (counted in heap_blocks(): memory is never a reason to lose or
// delay a write) and make_in_pool() gives null (a read ahead can wait).
// Thread-safe. Blocks may outlive the pool object: the region goes when its last block does.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>

#include "chungs/gaussians/block_arrays.hpp"

namespace chungs {

namespace detail {
struct HostRegion;
}

class HostBlock {
 public:
  HostBlock() = default;  // no Gaussians
  ~HostBlock();
  HostBlock(const HostBlock&) = delete;
  HostBlock& operator=(const HostBlock&) = delete;

  size_t size() const { return arrays_.count; }
  int sh_degree() const { return arrays_.sh_degree; }
  const BlockArrays& arrays() { return arrays_; }
  ConstBlockArrays arrays() const { return arrays_; }
  bool in_pool() const { return region_ != nullptr; }

 private:
  friend class HostBlockPool;
  std::shared_ptr<detail::HostRegion> region_;  // set: [offset_, offset_ + bytes_) of it
  size_t offset_ = 0, bytes_ = 0;
  std::unique_ptr<std::byte[]> heap_;  // when the pool had no room
  BlockArrays arrays_;
};

class HostBlockPool {
 public:
  // Address space for `bytes` (rounded up to whole pages); no memory is taken until it is used or
  // make_resident(). 0, or a mapping the system refuses: every block comes from the heap.
  explicit HostBlockPool(size_t bytes);
  HostBlockPool(const HostBlockPool&) = delete;
  HostBlockPool& operator=(const HostBlockPool&) = delete;

  // Writes every page once: from now on the pool is resident, whatever the queues hold.
  void make_resident();
  // A block of `count` Gaussians (uninitialised values): in the pool where a free range fits, else
  // from the heap. Throws std::bad_alloc only when the heap has no room either.
  std::shared_ptr<HostBlock> make(size_t count, int sh_degree);
  // The same, but null instead of a heap block when the pool has no room.
  std::shared_ptr<HostBlock> make_in_pool(size_t count, int sh_degree);

  size_t capacity_bytes() const;
  size_t used_bytes() const;       // in pool blocks now
  size_t peak_used_bytes() const;  // the most used_bytes() has been
  uint64_t heap_blocks() const;    // blocks make() took from the heap for want of room
  bool resident() const;

  // Bytes a block of `count` Gaussians takes in the pool (its arrays, rounded up to whole units).
  static size_t block_bytes(size_t count);

 private:
  std::shared_ptr<detail::HostRegion> region_;  // null: no pool memory
};

}  // namespace chungs
