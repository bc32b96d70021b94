#include "chungs/residency/gaussian_pool.hpp"

#include <algorithm>
#include <cstring>

#include "chungs/common/error.hpp"

namespace chungs {

GaussianPool::GaussianPool(size_t capacity, int sh_degree) : sh_degree_(sh_degree), in_use_(capacity, 0) {
  if (capacity > size_t(UINT32_MAX)) fail("Gaussian pool: capacity ", capacity, " exceeds 32-bit slot indices");
  if (sh_degree < 0 || sh_degree > kMaxShDegree) fail("Gaussian pool: SH degree ", sh_degree, " out of range");
  free_.resize(capacity);
  for (size_t i = 0; i < capacity; ++i) free_[i] = uint32_t(capacity - 1 - i);
}

std::vector<uint32_t> GaussianPool::allocate(size_t n) {
  if (n > free_.size())
    fail("Gaussian pool: ", n, " slots requested but only ", free_.size(), " of ", capacity(), " are free");
  std::vector<uint32_t> out(free_.end() - std::ptrdiff_t(n), free_.end());
  std::reverse(out.begin(), out.end());
  free_.resize(free_.size() - n);
  for (uint32_t s : out) in_use_[s] = 1;
  return out;
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
    if (!in_use_[s]) fail("Gaussian pool: ", what, " of slot ", s, ", which is free");
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
  storage_.resize(capacity);
}

void CpuGaussianPool::scatter_impl(const GaussianBlock& block, std::span<const uint32_t> slots) {
  copy_block<true>(storage_, block, slots);
}

void CpuGaussianPool::gather_impl(std::span<const uint32_t> slots, GaussianBlock& out) const {
  copy_block<false>(out, storage_, slots);
}

}  // namespace chungs
