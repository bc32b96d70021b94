#ifdef CHUNGS_WITH_CUDA
#include "chungs/residency/cuda/gaussian_pool.hpp"

#include <array>

#include "chungs/residency/cuda/pool_device.hpp"

namespace chungs::cuda {

namespace {

// The 19 arrays of a GaussianBlock in one fixed order: params, m, v (5 kinds each), then the
// per-Gaussian words.
constexpr int kArrays = 19;
constexpr std::array<int, kArrays> kWidths = {3, 3, 4, 1, kShFloats, 3, 3, 4, 1, kShFloats,
                                              3, 3, 4, 1, kShFloats, 1, 1, 1, 1};

template <typename Block, typename Ptr>
std::array<Ptr, kArrays> arrays_of(Block& b) {
  std::array<Ptr, kArrays> out{};
  int a = 0;
  for (auto* p : {&b.params, &b.adam_m, &b.adam_v}) {
    out[a++] = p->mean.data();
    out[a++] = p->log_scale.data();
    out[a++] = p->rotation.data();
    out[a++] = p->opacity.data();
    out[a++] = p->sh.data();
  }
  out[a++] = b.adam_steps.data();
  out[a++] = b.created_by_keyframe.data();
  out[a++] = b.created_at_step.data();
  out[a++] = b.lr_position_factor.data();
  return out;
}

}  // namespace

CudaGaussianPool::CudaGaussianPool(size_t capacity, int sh_degree) : GaussianPool(capacity, sh_degree) {
  dev_ = detail::pool_device_create(allocated(), kWidths.data(), kArrays);
  refresh_arrays(allocated());
}

void CudaGaussianPool::refresh_arrays(size_t slots) {
  auto f = [&](int a) { return static_cast<float*>(detail::pool_device_array(dev_, a)); };
  for (int s = 0; s < 3; ++s) {
    arrays_.mean[s] = f(5 * s);
    arrays_.log_scale[s] = f(5 * s + 1);
    arrays_.rotation[s] = f(5 * s + 2);
    arrays_.opacity[s] = f(5 * s + 3);
    arrays_.sh[s] = f(5 * s + 4);
  }
  arrays_.adam_steps = static_cast<uint32_t*>(detail::pool_device_array(dev_, 15));
  arrays_.created_by_keyframe = static_cast<uint32_t*>(detail::pool_device_array(dev_, 16));
  arrays_.created_at_step = static_cast<uint32_t*>(detail::pool_device_array(dev_, 17));
  arrays_.lr_position_factor = f(18);
  arrays_.capacity = slots;
}

void CudaGaussianPool::grow_impl(size_t slots) {
  try {
    detail::pool_device_grow(dev_, slots);
  } catch (...) {
    refresh_arrays(allocated());  // some arrays may have moved, each still holding allocated() slots
    throw;
  }
  refresh_arrays(slots);
}

CudaGaussianPool::~CudaGaussianPool() { detail::pool_device_destroy(dev_); }

void CudaGaussianPool::wait_uploads() { detail::pool_device_wait_uploads(dev_); }
void CudaGaussianPool::synchronize() { detail::pool_device_synchronize(dev_); }

void CudaGaussianPool::scatter_impl(const GaussianBlock& block, std::span<const uint32_t> slots) {
  const auto src = arrays_of<const GaussianBlock, const void*>(block);
  detail::pool_device_scatter(dev_, src.data(), slots.data(), slots.size());
}

void CudaGaussianPool::gather_impl(std::span<const uint32_t> slots, GaussianBlock& out) const {
  const auto dst = arrays_of<GaussianBlock, void*>(out);
  detail::pool_device_gather(dev_, dst.data(), slots.data(), slots.size());
}

}  // namespace chungs::cuda
#endif
