// Pruning rule of the mapper: Gaussians that became nearly transparent or cover too much of the
// image are removed (DiskChunGS: every 10 iterations, opacity < 0.05 or screen size > 0.5 W).
#pragma once
#include <cstdint>
#include <span>
#include <vector>

#include "chungs/render/gaussian_view.hpp"

namespace chungs {

struct PruneConfig {
  float min_opacity = 0.05f;         // sigmoid(logit) below this is pruned
  float max_radius_fraction = 0.5f;  // screen radius (3 sigma, px) above this * image width is pruned
  int every = 10;                    // optimiser iterations between pruning passes (the mapper's schedule)
  void validate() const;
};

// Slots among ids to remove. The opacity test applies to every listed Gaussian; the size test to
// those with a screen radius from the last render (radius[j], rasterizer layout; 0 = not visible).
// radius may be empty (size test skipped). Throws Error when sizes disagree.
std::vector<uint32_t> select_for_pruning(const PruneConfig& config, const GaussianArrays<float>& g,
                                         std::span<const uint32_t> ids, std::span<const float> radius,
                                         int image_width);

}  // namespace chungs
