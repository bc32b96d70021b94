#include "chungs/depth/depth_refine.hpp"

#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

DepthRefineStats refine_depths(const PlaneSweepInput& input, std::vector<PixelDepth>& pixels, double inv_range,
                               const PlaneSweepConfig& sweep) {
  if (!(inv_range > 0) || !std::isfinite(inv_range))
    fail("depth refinement: the inverse-depth range ", inv_range, " must be positive");
  const int w = input.camera.width, h = input.camera.height;
  // The measurement travels to the sweep as its prior (prior_abs_range makes the band absolute); the
  // image holds it only at the asked pixels, so every other pixel would get no depth.
  ImageF prior(w, h, 1, 0.0f);
  std::vector<size_t> at;  // index into pixels of each swept pixel
  std::vector<SweepPixel> swept;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const PixelDepth& p = pixels[i];
    if (p.x < 0 || p.y < 0 || p.x >= w || p.y >= h)
      fail("depth refinement: pixel ", i, " (", p.x, ", ", p.y, ") lies outside the ", w, "x", h, " image");
    if (!(p.depth > 0) || !std::isfinite(p.depth)) continue;
    float& slot = prior(p.x, p.y);
    if (slot != 0) fail("depth refinement: pixel (", p.x, ", ", p.y, ") is given twice");
    slot = 1.0f / p.depth;
    at.push_back(i);
    swept.push_back({p.x, p.y});
  }
  DepthRefineStats stats;
  stats.asked = swept.size();
  if (swept.empty()) return stats;
  PlaneSweepInput in = input;
  in.prior_inv_depth = &prior;
  in.prior_confidence = nullptr;  // every measurement counts as confident
  PlaneSweepConfig c = sweep;
  c.prior_abs_range = inv_range;
  c.min_prior_confidence = 0;
  const std::vector<SweepSample> out = plane_sweep_at(in, swept, c);
  for (size_t k = 0; k < out.size(); ++k)
    if (out[k].depth > 0 && std::isfinite(out[k].depth)) {
      pixels[at[k]].depth = out[k].depth;
      ++stats.refined;
    }
  return stats;
}

}  // namespace chungs
