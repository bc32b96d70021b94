// Internal: the fused loss kernels' arguments as plain C++17 data (loss.cu compiles as C++17 and
// cannot see chungs/optim/loss.hpp).
#pragma once
#include <cstdint>

namespace chungs::cuda::detail {

struct LossLaunch {
  int width, height;
  const float* rgb;         // rendered, 3 channels interleaved
  const float* target_rgb;  // same shape
  const float* inv_depth;   // rendered, 1 channel; used when depth_weight > 0
  const float* target_inv_depth;
  const uint8_t* depth_mask;                   // optional
  const uint8_t* pixel_mask;                   // optional: gradients are zeroed where it is 0
  float l1_weight, ssim_weight, depth_weight;  // (1 - ls), ls, ld; a zero weight skips the term
  bool want_grads;
  float* grad_rgb;        // overwritten: (1 - ls) dL1 - ls dSSIM
  float* grad_inv_depth;  // overwritten where the depth term is on
  float* ssim_planes;     // scratch, 9 planes of width x height
  double* sums;           // scratch, 4 doubles: sum |d|, sum SSIM, sum |d inv|, valid depth pixels
  double* partials;       // scratch, 4 x kLossSpread doubles the blocks add into (then into sums)
};

constexpr int kLossSpread = 64;

// Pinned host memory for the 4 sums and an event after their copy: the sums are read once the
// kernels queued after the loss (the rasterizer's backward, Adam) are launched, so the device never
// waits for the host to read them.
struct LossReadback;
LossReadback* loss_readback_create();
void loss_readback_destroy(LossReadback* rb);
// Queues the kernels and the copy of the 4 sums into rb; returns at once. Throws Error on a CUDA failure.
void launch_mapping_loss(const LossLaunch& a, LossReadback* rb);
// Waits for the sums of the last launch into rb and copies them to sums[4].
void loss_readback_wait(LossReadback* rb, double* sums);

// The 11-tap Gaussian window (sigma 1.5) of the SSIM, computed as the CPU twin does.
void ssim_window(float* w11);

}  // namespace chungs::cuda::detail
