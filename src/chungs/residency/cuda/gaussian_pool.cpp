#ifdef CHUNGS_WITH_CUDA
#include "chungs/residency/cuda/gaussian_pool.hpp"

#include <vector>

#include "chungs/residency/cuda/pool_device.hpp"

namespace chungs::cuda {

CudaGaussianPool::CudaGaussianPool(size_t capacity, int sh_degree) : GaussianPool(capacity, sh_degree) {
  dev_ = detail::pool_device_create(allocated(), kBlockArrayWidths.data(), kBlockArrays);
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

namespace {
template <class Arrays>
std::vector<detail::HostArrays> host_arrays(std::span<const Arrays> blocks) {
  std::vector<detail::HostArrays> out;
  out.reserve(blocks.size());
  for (const Arrays& b : blocks) out.push_back({reinterpret_cast<const void* const*>(b.data.data()), b.count});
  return out;
}
}  // namespace

void CudaGaussianPool::scatter_impl(const ConstBlockArrays& block, std::span<const uint32_t> slots) {
  scatter_blocks_impl(std::span(&block, 1), slots);
}

void CudaGaussianPool::gather_impl(std::span<const uint32_t> slots, const BlockArrays& out) const {
  gather_blocks_impl(slots, std::span(&out, 1));
}

void CudaGaussianPool::scatter_blocks_impl(std::span<const ConstBlockArrays> blocks, std::span<const uint32_t> slots) {
  const std::vector<detail::HostArrays> h = host_arrays(blocks);
  detail::pool_device_scatter(dev_, h.data(), h.size(), slots.data(), slots.size());
}

void CudaGaussianPool::gather_blocks_impl(std::span<const uint32_t> slots, std::span<const BlockArrays> outs) const {
  const std::vector<detail::HostArrays> h = host_arrays(outs);
  detail::pool_device_gather(dev_, h.data(), h.size(), slots.data(), slots.size());
}

}  // namespace chungs::cuda
#endif
