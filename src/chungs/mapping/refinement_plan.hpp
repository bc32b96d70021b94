// How the refinement after the last frame (mapper.final_iterations) spreads its steps: over every
// keyframe of the map, not only those near the end of the drive. The keyframes are cut into groups
// whose views fit a share of the budget together, so that each group's chunks are loaded once; each
// group gets the steps in proportion to its keyframes, spent in passes over it in a fresh random order.
//
// A group is a place, not a stretch of the drive: it grows from the earliest keyframe not yet grouped
// by the keyframe whose view adds the fewest Gaussians to it, so that the views of a street driven twice
// (a loop, a way back) are trained together. Under a budget that is what the map lacks against one that
// fits: the steps a place gets from every view of it together (bench/README.md, issue 19).
//
// The order within a group matters: one step on every keyframe of a 2 km street in the order of the
// drive lowered the held-out PSNR by 1.2 dB on the GPU, the same steps shuffled raised it by 0.4 dB:
// consecutive neighbouring views push the Gaussians they share the same way, step after step, and
// Adam's momentum adds it up. The same holds between groups, more weakly: a chunk that several groups
// see (far chunks are seen from many places) ends fitted to the last of them. Refined one group after
// the other under 300 k, a map scored 0.4 dB under the same steps at random over the whole map on the
// GPU, and rounds over the groups (refinement_visits) trade chunk loads for that order.
#pragma once
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "chungs/common/mapped_allocator.hpp"
#include "chungs/residency/budget_groups.hpp"

namespace chungs {

struct RefinementGroup {
  std::vector<size_t> keyframes;  // indices into the views, in the order they joined the group
  uint64_t steps = 0;             // the group's share of the steps
};

// Every keyframe's view, packed: 8 bytes a chunk seen (its number here, its Gaussians), where a
// vector of ChunkCount a keyframe, with the plan's lookup by chunk beside it, took ~40. The plan
// needs every view at once, so its memory grows with the drive, and the heap keeps its peak
// (common/heap.hpp): for 5,100 views of ~110 chunks (a 10 km drive) 25 MB, packed 8 MB. The plan's
// arrays are mapped for it and given back after (common/mapped_allocator.hpp).
class PackedViews {
 public:
  // The next keyframe's view. Throws Error for a chunk of more than 2^32 - 1 Gaussians.
  void add(const std::vector<ChunkCount>& view);
  size_t size() const { return start_.size() - 1; }
  size_t chunks() const { return ids_.size(); }
  // View k's entries are [begin(k), end(k)): number(e) is the chunk, count(e) its Gaussians.
  uint32_t begin(size_t k) const { return start_[k]; }
  uint32_t end(size_t k) const { return start_[k + 1]; }
  uint32_t number(uint32_t e) const { return number_[e]; }
  uint32_t count(uint32_t e) const { return count_[e]; }

 private:
  MappedVector<uint32_t> start_{0}, number_, count_;
  MappedVector<ChunkId> ids_;                          // by number
  std::unordered_map<ChunkId, uint32_t> numbered_;  // the inverse
};

// `views`: the chunks each keyframe (in the order keyframes were added) sees, with their Gaussians.
// A group starts at the earliest keyframe left and takes, one at a time, the keyframe that adds the
// fewest Gaussians not yet in the group, among those sharing a chunk with it and the earliest keyframe
// left (ties: the earlier keyframe), while that keeps the group's distinct chunks within `fit`
// Gaussians (a keyframe that alone needs more is a group of its own). A map that fits is one group.
// Shares: with n_g keyframes before group g, it gets floor(steps * (n_g + size_g) / K) -
// floor(steps * n_g / K). Throws Error when `fit` is 0.
std::vector<RefinementGroup> plan_refinement(const PackedViews& views, uint64_t fit, uint64_t steps);

// The order the groups are trained in: R rounds over the groups in turn. Group g, of n_g keyframes, is
// visited r_g = max(min(rounds, max(1, s_g / min_visit_steps)), ceil(s_g / n_g)) times (n_g counted as
// 1 when 0), spread evenly over the rounds (in round r when floor((r + 1) r_g / R) > floor(r r_g / R)),
// with R = max(rounds, every r_g); its visit j gets floor(s_g (j + 1) / r_g) - floor(s_g j / r_g) of its
// steps. Each visit loads the group's chunks again: a visit of a few steps keeps that a share of a view
// per step, where a group of two views under a budget of one (100 k on the 2 km street) visited for one
// step at a time would load a whole group per step. But a visit never trains its keyframes more than
// about once each: a group of two views given 15 steps in 3 visits of 5 trained each view 2-3 times in a
// row, and 4x the refinement steps lowered the map under a budget of 40 % of a view by 0.45 dB (where
// without a budget they raised it by 0.8 dB); as passes of one step a keyframe they raise it by 1.0 dB
// (bench/README.md, issue 19). r_g is held to 2^20 / (number of groups) at most (the list's size).
// Visits of no step are left out. Throws Error when rounds or min_visit_steps is 0.
struct RefinementVisit {
  size_t group = 0;
  uint64_t steps = 0;
};
std::vector<RefinementVisit> refinement_visits(const std::vector<RefinementGroup>& groups, size_t rounds,
                                              uint64_t min_visit_steps);

}  // namespace chungs
