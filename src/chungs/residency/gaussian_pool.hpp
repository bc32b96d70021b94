// GaussianPool: storage for Gaussians (parameters + Adam state + bookkeeping) with a free list of
// slots. A resident chunk owns a list of slots; loading scatters a chunk's block into free slots,
// evicting gathers its slots back into a block. Renderers and the optimiser work on the pool's
// arrays through index lists of visible slots, so nothing is concatenated per step.
//
// The slot bookkeeping lives here, on the host, for every implementation; subclasses own the
// arrays (CpuGaussianPool in RAM, CudaGaussianPool in VRAM) and grow them on demand: a small map
// (a test, a room, a render of a few chunks) takes memory for what it holds, not for the budget.
// Arrays start at a few thousand slots and double when a slot beyond them is handed out; once a
// doubling would pass half the capacity they take all of it, so a run that fills its budget has
// its final arrays early and memory stays level from then on. Slot numbers never change on growth;
// raw pointers into the arrays do, so callers fetch them again after anything that allocates.
#pragma once
#include <cstdint>
#include <span>
#include <vector>

#include "chungs/gaussians/block_arrays.hpp"

namespace chungs {

class GaussianPool {
 public:
  static constexpr size_t kMaxCapacity = UINT32_MAX;  // slots are 32-bit indices
  static constexpr size_t kInitialSlots = 4096;       // arrays at construction (or the capacity)

  explicit GaussianPool(size_t capacity, int sh_degree = kMaxShDegree);
  virtual ~GaussianPool() = default;
  GaussianPool(const GaussianPool&) = delete;
  GaussianPool& operator=(const GaussianPool&) = delete;

  size_t capacity() const { return capacity_; }    // the most slots it may ever hold
  size_t allocated() const { return allocated_; }  // slots its arrays hold now (<= capacity)
  size_t free_count() const { return free_.size() + (capacity_ - fresh_); }
  size_t used() const { return fresh_ - free_.size(); }
  int sh_degree() const { return sh_degree_; }
  bool in_use(uint32_t slot) const { return slot < in_use_.size() && in_use_[slot]; }

  // Takes n free slots: released ones first (the latest first), then never used ones, lowest
  // first. Throws Error when fewer than n are free; growing the arrays may throw std::bad_alloc
  // (or Error for device memory), and then every slot is as it was.
  std::vector<uint32_t> allocate(size_t n);
  // Returns slots to the free list; throws on a slot out of range, free, or listed twice.
  void release(std::span<const uint32_t> slots);

  // Copies Gaussian i of `block` into slots[i]; slots must be allocated, sizes must agree.
  void scatter(const GaussianBlock& block, std::span<const uint32_t> slots);
  void scatter(const ConstBlockArrays& block, std::span<const uint32_t> slots);
  // Replaces `out` with the Gaussians of `slots`, in that order (sh_degree = the pool's).
  void gather(std::span<const uint32_t> slots, GaussianBlock& out) const;
  // The same into arrays held elsewhere, with room for exactly slots.size() Gaussians.
  void gather(std::span<const uint32_t> slots, const BlockArrays& out) const;
  // Several blocks laid end to end against one list of slots, in one transfer where the pool's
  // memory is far (a GPU: one round trip for all, not one per block, and no host copy in between).
  void scatter(std::span<const ConstBlockArrays> blocks, std::span<const uint32_t> slots);
  void gather(std::span<const uint32_t> slots, std::span<const BlockArrays> outs) const;

 protected:
  // Makes the arrays hold `slots` (> allocated()), keeping slots [0, allocated()) as they are;
  // throws when the memory cannot be had, with those slots still as they are.
  virtual void grow_impl(size_t slots) = 0;
  virtual void scatter_impl(const ConstBlockArrays& block, std::span<const uint32_t> slots) = 0;
  virtual void gather_impl(std::span<const uint32_t> slots, const BlockArrays& out) const = 0;
  // Block by block unless a pool moves them at once.
  virtual void scatter_blocks_impl(std::span<const ConstBlockArrays> blocks, std::span<const uint32_t> slots);
  virtual void gather_blocks_impl(std::span<const uint32_t> slots, std::span<const BlockArrays> outs) const;

 private:
  void check_allocated(std::span<const uint32_t> slots, const char* what) const;
  void grow_to_hold(size_t slots);

  size_t capacity_;
  size_t allocated_;
  size_t fresh_ = 0;  // slots [fresh_, capacity_) were never handed out
  int sh_degree_;
  std::vector<uint32_t> free_;   // released slots, a stack: the most recently released is reused first
  std::vector<uint8_t> in_use_;  // one entry per slot of the arrays
};

// The pool in host memory: one GaussianBlock of allocated() Gaussians, indexed by slot.
class CpuGaussianPool final : public GaussianPool {
 public:
  explicit CpuGaussianPool(size_t capacity, int sh_degree = kMaxShDegree);

  // Raw structure-of-arrays access for renderers and the optimiser: Gaussian of slot s is entry
  // s of every array. Only slots that are in_use() hold meaningful data. allocate() may move the
  // arrays: take views (view_of(params())) after it, never keep them across it.
  GaussianBlock& storage() { return storage_; }
  const GaussianBlock& storage() const { return storage_; }
  GaussianParams& params() { return storage_.params; }
  const GaussianParams& params() const { return storage_.params; }

 protected:
  void grow_impl(size_t slots) override;
  void scatter_impl(const ConstBlockArrays& block, std::span<const uint32_t> slots) override;
  void gather_impl(std::span<const uint32_t> slots, const BlockArrays& out) const override;

 private:
  GaussianBlock storage_;
};

}  // namespace chungs
