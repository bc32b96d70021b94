// What a render produces, and the gradients of a loss with respect to it that the backward pass
// consumes.
#pragma once
#include <cstdint>
#include <limits>
#include <vector>

#include "chungs/image/image.hpp"

namespace chungs {

constexpr uint32_t kNoGaussian = std::numeric_limits<uint32_t>::max();

// Images are width x height. With w_i = alpha_i * T_i the compositing weight of splat i at a pixel:
//   rgb       = sum w_i c_i + T_final * background
//   depth     = sum w_i z_i        (view-space z; NOT divided by alpha: divide by `alpha` for the
//                                   expected depth of the covered part)
//   inv_depth = sum w_i / z_i      (also not normalised: this equals compositing over a background at
//                                   infinite depth, so it is directly comparable with a measured
//                                   inverse depth, and empty pixels read 0 = infinitely far)
//   alpha     = 1 - T_final = sum w_i
//   top_id    = pool slot of the splat with the largest w_i at the pixel, kNoGaussian if none
// Per rendered index j (position in the index list, not the slot):
//   visible[j] = 1 when the Gaussian reaches at least one pixel (in front of the near plane, inside
//                the image, opacity above the alpha cut-off)
//   radius[j]  = 3 sigma of the major axis of its 2D footprint, pixels (0 when culled)
template <typename T>
struct RenderOutput {
  Image<T> rgb;        // 3 channels
  Image<T> depth;      // 1 channel
  Image<T> inv_depth;  // 1 channel
  Image<T> alpha;      // 1 channel
  Image<uint32_t> top_id;
  std::vector<uint8_t> visible;
  std::vector<T> radius;
};

// dLoss/dOutput, same shapes as the outputs. An empty image means a zero gradient.
template <typename T>
struct RenderGrads {
  Image<T> rgb, depth, inv_depth, alpha;
};

}  // namespace chungs
