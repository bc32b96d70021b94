// Host side of the fused CUDA mapping loss: argument checks, buffers, the sums into LossTerms.
#ifdef CHUNGS_WITH_CUDA
#include "chungs/optim/cuda/loss.hpp"

#include "chungs/common/error.hpp"
#include "chungs/optim/cuda/loss_launch.hpp"

namespace chungs::cuda {

CudaMappingLoss::CudaMappingLoss() : readback_(detail::loss_readback_create()) {}

CudaMappingLoss::~CudaMappingLoss() { detail::loss_readback_destroy(readback_); }

LossTerms CudaMappingLoss::evaluate(const LossConfig& config, const DeviceRenderOutput& render,
                                    const float* target_rgb, const float* target_inv_depth,
                                    const uint8_t* depth_mask, bool want_grads, const uint8_t* pixel_mask) {
  launch(config, render, target_rgb, target_inv_depth, depth_mask, want_grads, pixel_mask);
  return finish();
}

void CudaMappingLoss::launch(const LossConfig& config, const DeviceRenderOutput& render, const float* target_rgb,
                             const float* target_inv_depth, const uint8_t* depth_mask, bool want_grads,
                             const uint8_t* pixel_mask) {
  config.validate();
  const int W = render.width, H = render.height;
  if (W <= 0 || H <= 0 || !render.rgb) fail("CUDA mapping loss: no rendered image (", W, "x", H, ")");
  if (!target_rgb) fail("CUDA mapping loss: target image missing (null pointer)");
  const double ls = config.lambda_ssim, ld = config.lambda_depth;
  const bool use_depth = target_inv_depth && ld > 0;
  if (use_depth && !render.inv_depth) fail("CUDA mapping loss: depth term without a rendered inverse depth");
  const size_t plane = size_t(W) * H;
  sums_.resize(4 + 4 * detail::kLossSpread);
  if (want_grads) {
    grad_rgb_.resize(3 * plane);
    if (ls > 0) planes_.resize(9 * plane);
    if (use_depth) grad_inv_depth_.resize(plane);
  }
  detail::LossLaunch a{W,
                       H,
                       render.rgb,
                       target_rgb,
                       render.inv_depth,
                       target_inv_depth,
                       depth_mask,
                       pixel_mask,
                       float(1 - ls),
                       float(ls),
                       use_depth ? float(ld) : 0.f,
                       want_grads,
                       want_grads ? grad_rgb_.data() : nullptr,
                       want_grads && use_depth ? grad_inv_depth_.data() : nullptr,
                       want_grads && ls > 0 ? planes_.data() : nullptr,
                       sums_.data(),
                       sums_.data() + 4};
  pending_ = false;
  detail::launch_mapping_loss(a, readback_);
  plane_ = plane, ls_ = ls, ld_ = ld, use_depth_ = use_depth, pending_ = true;
  grads_ = DeviceRenderGrads{};
  if (want_grads) {
    grads_.rgb = grad_rgb_.data();
    if (use_depth) grads_.inv_depth = grad_inv_depth_.data();
  }
}

LossTerms CudaMappingLoss::finish() {
  if (!pending_) fail("CUDA mapping loss: no launched loss to finish");
  pending_ = false;
  double s[4];
  detail::loss_readback_wait(readback_, s);
  const size_t plane = plane_;
  const double ls = ls_, ld = ld_;
  const bool use_depth = use_depth_;
  LossTerms t;
  t.l1 = s[0] / double(3 * plane);
  t.ssim = ls > 0 ? s[1] / double(3 * plane) : 1.0;
  t.depth_pixels = use_depth ? size_t(s[3]) : 0;
  t.depth = use_depth && s[3] > 0 ? s[2] / s[3] : 0.0;
  t.total = (1 - ls) * t.l1 + ls * (1 - t.ssim) + (use_depth ? ld * t.depth : 0.0);
  return t;
}

}  // namespace chungs::cuda
#endif
