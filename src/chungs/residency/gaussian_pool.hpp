// GaussianPool: fixed-capacity storage for Gaussians (parameters + Adam state + bookkeeping) with a
// free list of slots. A resident chunk owns a list of slots; loading scatters a chunk's block into
// free slots, evicting gathers its slots back into a block. Renderers and the optimiser work on
// the pool's arrays through index lists of visible slots, so nothing is concatenated per step.
//
// The slot bookkeeping lives here, on the host, for every implementation; subclasses own the
// arrays (CpuGaussianPool in RAM now; a CUDA pool keeps them in VRAM and implements scatter and
// gather as host<->device copies with index kernels).
#pragma once
#include <cstdint>
#include <span>
#include <vector>

#include "chungs/gaussians/gaussian_block.hpp"

namespace chungs {

class GaussianPool {
 public:
  explicit GaussianPool(size_t capacity, int sh_degree = kMaxShDegree);
  virtual ~GaussianPool() = default;
  GaussianPool(const GaussianPool&) = delete;
  GaussianPool& operator=(const GaussianPool&) = delete;

  size_t capacity() const { return in_use_.size(); }
  size_t free_count() const { return free_.size(); }
  size_t used() const { return capacity() - free_count(); }
  int sh_degree() const { return sh_degree_; }
  bool in_use(uint32_t slot) const { return slot < in_use_.size() && in_use_[slot]; }

  // Takes n free slots (lowest first on a fresh pool); throws Error when fewer than n are free.
  std::vector<uint32_t> allocate(size_t n);
  // Returns slots to the free list; throws on a slot out of range, free, or listed twice.
  void release(std::span<const uint32_t> slots);

  // Copies Gaussian i of `block` into slots[i]; slots must be allocated, sizes must agree.
  void scatter(const GaussianBlock& block, std::span<const uint32_t> slots);
  // Replaces `out` with the Gaussians of `slots`, in that order (sh_degree = the pool's).
  void gather(std::span<const uint32_t> slots, GaussianBlock& out) const;

 protected:
  virtual void scatter_impl(const GaussianBlock& block, std::span<const uint32_t> slots) = 0;
  virtual void gather_impl(std::span<const uint32_t> slots, GaussianBlock& out) const = 0;

 private:
  void check_allocated(std::span<const uint32_t> slots, const char* what) const;

  int sh_degree_;
  std::vector<uint32_t> free_;  // a stack: the most recently released slot is reused first
  std::vector<uint8_t> in_use_;
};

// The pool in host memory: one GaussianBlock of `capacity` Gaussians, indexed by slot.
class CpuGaussianPool final : public GaussianPool {
 public:
  explicit CpuGaussianPool(size_t capacity, int sh_degree = kMaxShDegree);

  // Raw structure-of-arrays access for renderers and the optimiser: Gaussian of slot s is entry
  // s of every array. Only slots that are in_use() hold meaningful data.
  GaussianBlock& storage() { return storage_; }
  const GaussianBlock& storage() const { return storage_; }
  GaussianParams& params() { return storage_.params; }
  const GaussianParams& params() const { return storage_.params; }

 protected:
  void scatter_impl(const GaussianBlock& block, std::span<const uint32_t> slots) override;
  void gather_impl(std::span<const uint32_t> slots, GaussianBlock& out) const override;

 private:
  GaussianBlock storage_;
};

}  // namespace chungs
