// How the refinement after the last frame (mapper.final_iterations) spreads its steps: over every
// keyframe of the map, not only those near the end of the drive. The keyframes, in the order they were
// added, are cut into consecutive groups whose views fit a share of the budget together, so that each
// group's chunks are loaded once; each group gets the steps in proportion to its keyframes, spent in
// passes over it in a fresh random order. The order matters: one step on every keyframe of a 2 km
// street in the order of the drive lowered the held-out PSNR by 1.2 dB on the GPU, the same steps
// shuffled raised it by 0.4 dB (bench/README.md, issue 19): consecutive neighbouring views push
// the Gaussians they share the same way, step after step, and Adam's momentum adds it up.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "chungs/residency/budget_groups.hpp"

namespace chungs {

struct RefinementGroup {
  size_t begin = 0, end = 0;  // keyframes [begin, end) in the order they were added
  uint64_t steps = 0;         // the group's share of the steps
};

// `views[k]`: the chunks keyframe k sees with their Gaussians. A group ends before the keyframe whose
// chunks would take the group's distinct chunks past `fit` Gaussians (a keyframe that alone needs
// more is a group of its own). Shares: group g gets floor(steps * end_g / K) - floor(steps * begin_g / K).
// Throws Error when `fit` is 0.
std::vector<RefinementGroup> plan_refinement(const std::vector<std::vector<ChunkCount>>& views, uint64_t fit,
                                             uint64_t steps);

}  // namespace chungs
