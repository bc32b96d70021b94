#include "chungs/residency/gaussian_pool.hpp"

#include <algorithm>
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
  if (block.size() != slots.size())
    fail("Gaussian pool: scatter of ", block.size(), " Gaussians into ", slots.size(), " slots");
  check_allocated(slots, "scatter");
  scatter_impl(block, slots);
}

void GaussianPool::gather(std::span<const uint32_t> slots, GaussianBlock& out) const {
  check_allocated(slots, "gather");
  out.sh_degree = sh_degree_;
  out.resize(slots.size());
  gather_impl(slots, out);
}

namespace {
template <int W, typename T>
void put(std::vector<T>& dst, const std::vector<T>& src, std::span<const uint32_t> slots) {
  for (size_t i = 0; i < slots.size(); ++i)
    std::memcpy(&dst[size_t(slots[i]) * W], &src[i * W], W * sizeof(T));
}
template <int W, typename T>
void get(std::vector<T>& dst, const std::vector<T>& src, std::span<const uint32_t> slots) {
  for (size_t i = 0; i < slots.size(); ++i)
    std::memcpy(&dst[i * W], &src[size_t(slots[i]) * W], W * sizeof(T));
}
template <bool Scatter>
void copy_params(GaussianParams& a, const GaussianParams& b, std::span<const uint32_t> s) {
  // Scatter: a = pool, b = block. Gather: a = block, b = pool.
  auto f = [&]<int W, typename T>(std::vector<T>& x, const std::vector<T>& y) {
    if constexpr (Scatter) put<W>(x, y, s); else get<W>(x, y, s);
  };
  f.template operator()<3>(a.mean, b.mean);
  f.template operator()<3>(a.log_scale, b.log_scale);
  f.template operator()<4>(a.rotation, b.rotation);
  f.template operator()<1>(a.opacity, b.opacity);
  f.template operator()<kShFloats>(a.sh, b.sh);
}
template <bool Scatter>
void copy_block(GaussianBlock& a, const GaussianBlock& b, std::span<const uint32_t> s) {
  copy_params<Scatter>(a.params, b.params, s);
  copy_params<Scatter>(a.adam_m, b.adam_m, s);
  copy_params<Scatter>(a.adam_v, b.adam_v, s);
  auto f = [&](auto& x, const auto& y) {
    if constexpr (Scatter) put<1>(x, y, s); else get<1>(x, y, s);
  };
  f(a.adam_steps, b.adam_steps);
  f(a.created_by_keyframe, b.created_by_keyframe);
  f(a.created_at_step, b.created_at_step);
  f(a.lr_position_factor, b.lr_position_factor);
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

void CpuGaussianPool::scatter_impl(const GaussianBlock& block, std::span<const uint32_t> slots) {
  copy_block<true>(storage_, block, slots);
}

void CpuGaussianPool::gather_impl(std::span<const uint32_t> slots, GaussianBlock& out) const {
  copy_block<false>(out, storage_, slots);
}

}  // namespace chungs
