// The mapping loss on the GPU, fused: (1 - ls) L1 + ls (1 - SSIM) + ld L1(inverse depth) with its
// gradient with respect to the rendered images, the same function as chungs::mapping_loss (its CPU
// twin) on device images. Include only from C++ files: no CUDA headers here.
#pragma once
#include <cstdint>

#include "chungs/optim/loss.hpp"
#include "chungs/render/cuda/device_buffer.hpp"
#include "chungs/render/cuda/rasterizer.hpp"

namespace chungs::cuda {

namespace detail {
struct LossReadback;
}

class CudaMappingLoss {
 public:
  // render's rgb (and inv_depth for the depth term) against the targets, all device images of the
  // render's size (target_rgb 3 channels; target_inv_depth, depth_mask 1 channel; both may be null:
  // no depth term). With want_grads, grads() holds dLoss/d(output) until the next call. pixel_mask
  // (device, 1 byte per pixel, may be null): gradients zeroed where it is 0, as the CPU twin does.
  LossTerms evaluate(const LossConfig& config, const DeviceRenderOutput& render, const float* target_rgb,
                     const float* target_inv_depth, const uint8_t* depth_mask, bool want_grads = true,
                     const uint8_t* pixel_mask = nullptr);
  // evaluate() in two halves: launch() queues the kernels (grads() is valid for the kernels queued
  // after it), finish() waits for the sums of the last launch. Queuing the backward between the two
  // keeps the device busy while the host waits for the loss.
  void launch(const LossConfig& config, const DeviceRenderOutput& render, const float* target_rgb,
              const float* target_inv_depth, const uint8_t* depth_mask, bool want_grads = true,
              const uint8_t* pixel_mask = nullptr);
  LossTerms finish();

  CudaMappingLoss();
  ~CudaMappingLoss();
  CudaMappingLoss(const CudaMappingLoss&) = delete;
  CudaMappingLoss& operator=(const CudaMappingLoss&) = delete;

  // rgb always; inv_depth only when the last call had a depth term; depth and alpha null.
  const DeviceRenderGrads& grads() const { return grads_; }

 private:
  DeviceArray<float> grad_rgb_, grad_inv_depth_, planes_;
  DeviceArray<double> sums_;
  DeviceRenderGrads grads_;
  detail::LossReadback* readback_ = nullptr;
  // What finish() needs of the last launch.
  size_t plane_ = 0;
  double ls_ = 0, ld_ = 0;
  bool use_depth_ = false, pending_ = false;
};

}  // namespace chungs::cuda
