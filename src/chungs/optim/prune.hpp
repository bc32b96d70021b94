// Pruning rule of the mapper: Gaussians that became nearly transparent are removed every 10 iterations
// (DiskChunGS: opacity < 0.05). The paper also removes those whose screen size in the step's view is
// above 0.5 W; here the limit is 2 W: a view passing next to a parked car or a tree sees its Gaussians
// larger than 0.5 W, and pruning them there takes the object from every other view. The more steps a
// keyframe gets, the more such views are pruned against, so more time made a worse map: on a 150 m
// street at 150 steps per keyframe, 20.5 dB at 0.5 W, 22.4 at 2 W, 22.6 without the test (bench/README.md,
// issue 20). Without any limit, a small room trained long grew floaters of 10 m and steps 10x slower.
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
  float max_radius_fraction = 2.0f;  // screen radius (3 sigma, px) above this * image width is pruned; 0: off
  int every = 10;                    // optimiser iterations between pruning passes (the mapper's schedule)
  int min_visits = 0;                // steps a Gaussian was visible in before the opacity test applies
  void validate() const;
};

// Places in ids (ascending) of the Gaussians to remove: their place names their chunk to the caller at
// once (Residency::remove_written_slots), where a slot would have to be looked up. The opacity test applies
// to every listed Gaussian; the size test to those with a screen radius from the last render (radius[j],
// rasterizer layout; 0 = not visible) when max_radius_fraction > 0. radius may be empty (size test skipped).
// visits holds each slot's count of optimiser steps it was visible in (the Adam step count), read when
// min_visits > 0; a non-finite opacity is pruned at any age. Throws Error when sizes disagree.
std::vector<uint32_t> select_for_pruning(const PruneConfig& config, const GaussianArrays<float>& g,
                                         std::span<const uint32_t> ids, std::span<const float> radius,
                                         int image_width, std::span<const uint32_t> visits = {});

}  // namespace chungs
