// The mapping loss on a render:  (1 - ls) * L1(rgb) + ls * (1 - SSIM(rgb)) + ld * L1(inverse depth),
// with its gradient with respect to the rendered images, ready for the rasterizer's backward.
#pragma once
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "chungs/image/image.hpp"
#include "chungs/optim/loss_config.hpp"
#include "chungs/render/render_output.hpp"

namespace chungs {

struct LossTerms {
  double total = 0;
  double l1 = 0;            // mean absolute RGB error
  double ssim = 0;          // mean SSIM (the loss uses 1 - ssim)
  double depth = 0;         // mean absolute inverse-depth error over valid pixels
  size_t depth_pixels = 0;  // valid pixels of the depth term
};

// target_inv_depth may be null (no depth supervision, or lambda_depth = 0); depth_mask may be null.
// When grads is given, its rgb (and inv_depth, when the depth term is on) are set to dLoss/d(output)
// and its other images are cleared. pixel_mask (1 channel, render size, may be null): the gradients
// are zeroed where it is 0, so that pixels a partial render cannot explain teach nothing (the terms
// are still those of the whole image).
template <typename T>
LossTerms mapping_loss(const LossConfig& config, const RenderOutput<T>& render, const Image<T>& target_rgb,
                       const Image<T>* target_inv_depth, const Image<uint8_t>* depth_mask,
                       std::type_identity_t<RenderGrads<T>>* grads, const Image<uint8_t>* pixel_mask = nullptr);

}  // namespace chungs
