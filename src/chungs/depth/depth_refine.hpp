// Refinement of measured depth (issue 25, item 4): RGB-D or stereo depth at chosen pixels (those the
// sampler draws) polished by the plane sweep (plane_sweep.hpp) against neighbouring keyframes, over a
// narrow band of inverse depth centred on the measurement: the paper's guided matching with its ranges
// for sensor (±0.05 1/m) and stereo (±0.01 1/m) depth. Where the sweep is not confident (texture,
// cost, uniqueness or parallax test, or the best match at an end of the band) the measurement stays.
//
// Why at the sampled pixels and not the whole keyframe: a dense sweep costs seconds per keyframe on
// the host (16-50 hypotheses x neighbours x a 7x7 patch per pixel), while the sampler draws a few per
// cent of the pixels; the depth loss keeps the measured depth map, which the paper does not refine
// either. Pixels are independent, so a subset is exactly what the dense result would give there.
#pragma once
#include <cstddef>
#include <vector>

#include "chungs/depth/plane_sweep.hpp"

namespace chungs {

struct PixelDepth {
  int x = 0, y = 0;
  float depth = 0;  // the poses' unit along the optical axis; <= 0 or not finite: none (left alone)
};

struct DepthRefineStats {
  size_t asked = 0;    // pixels with a depth to refine
  size_t refined = 0;  // of them, replaced by the sweep's depth
};

// Sweeps each pixel with a depth over 1/depth -+ inv_range (1 / the poses' unit) against
// input.neighbours (input's priors are ignored) and replaces the depth where the sweep is confident.
// sweep: the sweep's settings (its prior_abs_range is set to inv_range; near and far bound the band).
// Throws Error on inv_range not positive and finite, a pixel outside the image or given twice, and
// the sweep's own checks (plane_sweep.hpp).
DepthRefineStats refine_depths(const PlaneSweepInput& input, std::vector<PixelDepth>& pixels, double inv_range,
                               const PlaneSweepConfig& sweep);

}  // namespace chungs
