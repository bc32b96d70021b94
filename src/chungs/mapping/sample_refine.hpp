// The depth refinement of a keyframe's sampled pixels (depth/depth_refine.hpp) inside the mapper:
// the neighbours are the most recent earlier keyframes the mapper holds (their images from the
// keyframe store, their poses as corrected so far), chosen by select_sweep_neighbours at the sampled
// pixels' median depth, as the monocular sweep chooses them (multiview_keyframes.hpp).
#pragma once
#include <cstdint>
#include <vector>

#include "chungs/depth/depth_refine.hpp"
#include "chungs/depth/multiview_depth.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/store/keyframe_store.hpp"

namespace chungs {

struct SampleRefineTotals {
  uint64_t samplings = 0;         // samplings refined (keyframes, resamplings)
  uint64_t without_neighbour = 0;  // ... that found no neighbour and kept their depth
  uint64_t asked = 0, refined = 0;  // pixels
  double ms = 0;
};

// Refines `pixels` (drawn from keyframe `id` seen by camera at pose) against up to config.neighbours
// of the last config.keep_keyframes records in `keyframes` other than id, with the same image size.
// inv_range: 1/m (the config's RGB-D or stereo range). A distorted camera is refused by the sweep.
// Adds to totals.
void refine_sampled_depths(const Camera& camera, const SE3& pose, uint32_t id,
                           const std::vector<KeyframeRecord>& keyframes, KeyframeStore& images,
                           const MultiviewDepthConfig& config, double inv_range, bool cuda,
                           std::vector<PixelDepth>& pixels, SampleRefineTotals& totals);

}  // namespace chungs
