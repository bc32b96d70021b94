// Pruning rule of the mapper: Gaussians that became nearly transparent or cover too much of the
// image are removed (DiskChunGS: every 10 iterations, opacity < 0.05 or screen size > 0.5 W).
// A new Gaussian starts at opacity 0.07, a few Adam steps above the threshold: with min_visits the
// opacity test waits until it has been optimised in that many steps, so that it is judged on what it
// became (off by default: the denser map it keeps costs quality under small budgets, bench/README).
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
  int min_visits = 0;                // steps a Gaussian was visible in before the opacity test applies
  void validate() const;
};

// Slots among ids to remove. The opacity test applies to every listed Gaussian; the size test to
// those with a screen radius from the last render (radius[j], rasterizer layout; 0 = not visible).
// radius may be empty (size test skipped). visits holds each slot's count of optimiser steps it was
// visible in (the Adam step count), read when min_visits > 0; a non-finite opacity is pruned at any
// age. Throws Error when sizes disagree.
std::vector<uint32_t> select_for_pruning(const PruneConfig& config, const GaussianArrays<float>& g,
                                         std::span<const uint32_t> ids, std::span<const float> radius,
                                         int image_width, std::span<const uint32_t> visits = {});

}  // namespace chungs
