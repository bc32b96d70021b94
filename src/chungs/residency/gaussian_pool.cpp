#include "chungs/residency/gaussian_pool.hpp"

#include <algorithm>
#include <cstddef>
#include <cstring>

#include "chungs/common/error.hpp"

namespace chungs {

GaussianPool::GaussianPool(size_t capacity, int sh_degree)
    : capacity_(capacity), allocated_(std::min(capacity, kInitialSlots)), sh_degree_(sh_degree) {
  if (capacity > kMaxCapacity) fail("Gaussian pool: capacity ", capacity, " exceeds 32-bit slot indices");
  if (sh_degree < 0 || sh_degree > kMaxShDegree) fail("Gaussian pool: SH degree ", sh_degree, " out of range");
  in_use_.assign(allocated_, 0);
}

std::vector<uint32_t> GaussianPool::allocate(size_t n) {
  if (n > free_count())
    fail("Gaussian pool: ", n, " slots requested but only ", free_count(), " of ", capacity(), " are free");
  const size_t reused = std::min(n, free_.size());
  // Grown before anything changes, so a failed growth leaves the pool as it was.
  if (fresh_ + (n - reused) > allocated_) grow_to_hold(fresh_ + (n - reused));
  std::vector<uint32_t> out(free_.rbegin(), free_.rbegin() + std::ptrdiff_t(reused));
  free_.resize(free_.size() - reused);
  out.reserve(n);
  while (out.size() < n) out.push_back(uint32_t(fresh_++));
  for (uint32_t s : out) in_use_[s] = 1;
  return out;
}

void GaussianPool::grow_to_hold(size_t slots) {
  size_t next = std::max(slots, 2 * allocated_);
  if (next > capacity_ / 2) next = capacity_;  // the last step: see the header
  in_use_.resize(next, 0);  // first: a failed grow_impl leaves only zeros beyond allocated_
  grow_impl(next);
  allocated_ = next;
}

void GaussianPool::release(std::span<const uint32_t> slots) {
  check_allocated(slots, "release");
  // Validate the whole list before changing anything: a failed release leaves the pool intact.
  for (size_t i = 0; i < slots.size(); ++i) {
    if (in_use_[slots[i]] == 2) {
      for (size_t j = 0; j < i; ++j) in_use_[slots[j]] = 1;
      fail("Gaussian pool: release lists slot ", slots[i], " twice");
    }
    in_use_[slots[i]] = 2;
  }
  for (uint32_t s : slots) {
    in_use_[s] = 0;
    free_.push_back(s);
  }
}

void GaussianPool::check_allocated(std::span<const uint32_t> slots, const char* what) const {
  for (uint32_t s : slots) {
    if (s >= capacity()) fail("Gaussian pool: ", what, " of slot ", s, " beyond capacity ", capacity());
    if (!in_use(s)) fail("Gaussian pool: ", what, " of slot ", s, ", which is free");
  }
}

void GaussianPool::scatter(const GaussianBlock& block, std::span<const uint32_t> slots) {
  block.validate("Gaussian pool scatter");
  scatter(block_arrays(block), slots);
}

void GaussianPool::scatter(const ConstBlockArrays& block, std::span<const uint32_t> slots) {
  if (block.count != slots.size())
    fail("Gaussian pool: scatter of ", block.count, " Gaussians into ", slots.size(), " slots");
  check_allocated(slots, "scatter");
  scatter_impl(block, slots);
}

void GaussianPool::gather(std::span<const uint32_t> slots, GaussianBlock& out) const {
  check_allocated(slots, "gather");
  out.sh_degree = sh_degree_;
  out.resize(slots.size());
  gather_impl(slots, block_arrays(out));
}

void GaussianPool::gather(std::span<const uint32_t> slots, const BlockArrays& out) const {
  if (out.count != slots.size())
    fail("Gaussian pool: gather of ", slots.size(), " slots into room for ", out.count, " Gaussians");
  check_allocated(slots, "gather");
  gather_impl(slots, out);
}

namespace {
size_t total_count(auto blocks) {
  size_t n = 0;
  for (const auto& b : blocks) n += b.count;
  return n;
}
}  // namespace

void GaussianPool::scatter(std::span<const ConstBlockArrays> blocks, std::span<const uint32_t> slots) {
  if (total_count(blocks) != slots.size())
    fail("Gaussian pool: scatter of ", total_count(blocks), " Gaussians into ", slots.size(), " slots");
  check_allocated(slots, "scatter");
  scatter_blocks_impl(blocks, slots);
}

void GaussianPool::gather(std::span<const uint32_t> slots, std::span<const BlockArrays> outs) const {
  if (total_count(outs) != slots.size())
    fail("Gaussian pool: gather of ", slots.size(), " slots into room for ", total_count(outs), " Gaussians");
  check_allocated(slots, "gather");
  gather_blocks_impl(slots, outs);
}

void GaussianPool::scatter_blocks_impl(std::span<const ConstBlockArrays> blocks, std::span<const uint32_t> slots) {
  for (const ConstBlockArrays& b : blocks) {
    scatter_impl(b, slots.first(b.count));
    slots = slots.subspan(b.count);
  }
}

void GaussianPool::gather_blocks_impl(std::span<const uint32_t> slots, std::span<const BlockArrays> outs) const {
  for (const BlockArrays& b : outs) {
    gather_impl(slots.first(b.count), b);
    slots = slots.subspan(b.count);
  }
}

namespace {
// Scatter: Gaussian i of the block to slot slots[i] of the pool; gather: the other way round. W
// 4-byte values per Gaussian, known at compile time so that each copy is a few moves.
template <bool Scatter, int W>
void copy_array(std::byte* pool, std::byte* block, std::span<const uint32_t> slots) {
  constexpr size_t kBytes = 4 * size_t(W);
  for (size_t i = 0; i < slots.size(); ++i) {
    std::byte* p = pool + size_t(slots[i]) * kBytes;
    std::byte* b = block + i * kBytes;
    if constexpr (Scatter)
      std::memcpy(p, b, kBytes);
    else
      std::memcpy(b, p, kBytes);
  }
}
template <bool Scatter>
void copy_arrays(const BlockArrays& pool, const BlockArrays& block, std::span<const uint32_t> slots) {
  for (int a = 0; a < kBlockArrays; ++a) {
    auto* p = static_cast<std::byte*>(pool.data[size_t(a)]);
    auto* b = static_cast<std::byte*>(block.data[size_t(a)]);
    switch (kBlockArrayWidths[size_t(a)]) {
      case 1: copy_array<Scatter, 1>(p, b, slots); break;
      case 3: copy_array<Scatter, 3>(p, b, slots); break;
      case 4: copy_array<Scatter, 4>(p, b, slots); break;
      case kShFloats: copy_array<Scatter, kShFloats>(p, b, slots); break;
      default: fail("Gaussian pool: no copy for arrays of width ", kBlockArrayWidths[size_t(a)]);
    }
  }
}
BlockArrays writable(const ConstBlockArrays& c) {  // only read through, by a scatter
  BlockArrays m;
  m.count = c.count;
  m.sh_degree = c.sh_degree;
  for (int a = 0; a < kBlockArrays; ++a) m.data[size_t(a)] = const_cast<void*>(c.data[size_t(a)]);
  return m;
}
}  // namespace

CpuGaussianPool::CpuGaussianPool(size_t capacity, int sh_degree) : GaussianPool(capacity, sh_degree) {
  storage_.sh_degree = sh_degree;
  storage_.resize(allocated());
}

void CpuGaussianPool::grow_impl(size_t slots) {
  storage_.reserve(slots);  // may throw, with every array as it was
  storage_.resize(slots);
}

void CpuGaussianPool::scatter_impl(const ConstBlockArrays& block, std::span<const uint32_t> slots) {
  copy_arrays<true>(block_arrays(storage_), writable(block), slots);
}

void CpuGaussianPool::gather_impl(std::span<const uint32_t> slots, const BlockArrays& out) const {
  copy_arrays<false>(writable(block_arrays(storage_)), out, slots);
}

}  // namespace chungs
