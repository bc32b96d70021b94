// SSIM as a differentiable training loss term: 11x11 Gaussian window (sigma 1.5), constants
// C1 = 0.01^2 and C2 = 0.03^2 for images in [0, 1], computed per channel and averaged over pixels and
// channels. The window is applied as a zero-padded "same" convolution, as in 3D Gaussian Splatting's
// training loss, so border pixels see a truncated window. (The evaluation metric lives in
// chungs/image; this one exists for its gradient.)
#pragma once
#include "chungs/image/image.hpp"

namespace chungs {

// Returns mean SSIM(pred, target). When grad is given (same shape as pred) it gets
// weight * dSSIM/dpred added. Throws Error when the shapes differ.
template <typename T>
double ssim_loss_term(const Image<T>& pred, const Image<T>& target, Image<T>* grad = nullptr,
                      double weight = 1.0);

}  // namespace chungs
