// The Gaussian pool in VRAM: the same slots and free list as every GaussianPool, with the arrays in
// device memory (plain cudaMalloc, one array per kind; growth copies them into bigger ones).
// scatter() (chunk load) and gather() (chunk eviction) move data through pinned staging buffers on
// the pool's own stream, so they overlap with rendering and optimisation queued on the default
// stream; they are ordered after that work.
// Include only from C++ files: no CUDA headers here.
#pragma once
#include <cstdint>

#include "chungs/residency/gaussian_pool.hpp"

namespace chungs::cuda {

namespace detail {
struct PoolDevice;
}

// Device pointers to the pool's arrays, slot s at entry s (widths as in GaussianBlock).
struct PoolDeviceArrays {
  float* mean[3];  // [0] parameters, [1] Adam m, [2] Adam v; likewise below
  float* log_scale[3];
  float* rotation[3];
  float* opacity[3];
  float* sh[3];
  uint32_t* adam_steps;
  uint32_t* created_by_keyframe;
  uint32_t* created_at_step;
  float* lr_position_factor;
  size_t capacity;  // slots the arrays hold now: the pool's allocated(), not its capacity()
};

class CudaGaussianPool final : public GaussianPool {
 public:
  // Throws Error when the device memory cannot be had.
  explicit CudaGaussianPool(size_t capacity, int sh_degree = kMaxShDegree);
  ~CudaGaussianPool() override;

  // Its pointers hold until the next allocate() (which may grow the arrays): read them per step.
  const PoolDeviceArrays& device_arrays() const { return arrays_; }
  // Work queued on the default stream after this call sees every scatter made before it.
  void wait_uploads();
  // Host wait for the pool's transfers.
  void synchronize();

 protected:
  void grow_impl(size_t slots) override;
  void scatter_impl(const ConstBlockArrays& block, std::span<const uint32_t> slots) override;
  void gather_impl(std::span<const uint32_t> slots, const BlockArrays& out) const override;
  void scatter_blocks_impl(std::span<const ConstBlockArrays> blocks, std::span<const uint32_t> slots) override;
  void gather_blocks_impl(std::span<const uint32_t> slots, std::span<const BlockArrays> outs) const override;

 private:
  void refresh_arrays(size_t slots);

  detail::PoolDevice* dev_ = nullptr;
  PoolDeviceArrays arrays_{};
};

}  // namespace chungs::cuda
