// Mapper::refine: the steps after the last frame, spread over the whole map by refinement_plan.hpp.
#include <algorithm>
#include <deque>

#include "chungs/common/error.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/refinement_plan.hpp"

namespace chungs {

Mapper::RefineStats Mapper::refine(uint64_t steps, const std::function<void(uint32_t)>& after_step) {
  RefineStats stats;
  if (steps == 0) return stats;
  if (keyframes_.empty()) fail("mapper: refinement needs at least one keyframe");
  give_back_picks_ahead();  // drawn for step(): their chunks and images are not what comes next
  std::vector<std::vector<ChunkCount>> views;
  views.reserve(keyframes_.size());
  for (const KeyframeRecord& kf : keyframes_) views.push_back(nearest_visible(kf.camera, kf.pose));
  // 0.8: room for the chunks read ahead while a group's last steps still hold theirs.
  const uint64_t fit = std::max<uint64_t>(1, uint64_t(0.8 * double(residency_->budget())));
  const std::vector<RefinementGroup> groups = plan_refinement(views, fit, steps);
  const size_t ahead = size_t(std::max(1, config_.mapper.read_ahead_steps));
  for (const RefinementGroup& g : groups) stats.groups += g.steps > 0;
  // The steps to come, a pass at a time, so that the read-ahead reaches into the next pass and the next
  // group: under a budget of about one view (100 k on the 2 km street) groups hold two views, and reads
  // that stopped at a group's end took the I/O wait of the run from 1.6 % to 2.65 % on the GPU.
  std::deque<size_t> queue;  // keyframe indices
  size_t group = 0;
  uint64_t left = groups.empty() ? 0 : groups[0].steps;
  std::vector<size_t> pass;
  const size_t reach = 1 + 4 * ahead;  // this step and the images read ahead
  const auto refill = [&] {
    while (queue.size() < reach + 1) {
      while (left == 0 && ++group < groups.size()) left = groups[group].steps;
      if (left == 0) return;
      pass = groups[group].keyframes;
      std::shuffle(pass.begin(), pass.end(), rng_);
      const size_t take = size_t(std::min<uint64_t>(left, pass.size()));
      for (size_t i = 0; i < take; ++i) queue.push_back(pass[i]);
      left -= take;
    }
  };
  for (refill(); !queue.empty(); refill()) {
    residency_->advance_checkpoint();
    if (!residency_->all_resident()) {
      // This step's chunks first, then those of the next few: read in the background meanwhile.
      std::vector<ChunkId> wanted;
      // The views were culled for the plan; the nearest chunks that fit the budget are what a step loads.
      for (size_t j = 0; j < std::min(queue.size(), 1 + ahead); ++j) {
        const BudgetGroups fits = split_by_budget(views[queue[j]], residency_->budget());
        if (!fits.groups.empty()) wanted.insert(wanted.end(), fits.groups[0].begin(), fits.groups[0].end());
      }
      residency_->prefetch(wanted);
    }
    // Images further ahead than chunks (they are small): a shuffled pass reads most keyframes from
    // disk. Farthest first, since the store serves its latest request first.
    for (size_t j = std::min(queue.size(), reach); j-- > 1;)
      keyframe_store_->prefetch(keyframes_[queue[j]].id);
    const uint32_t id = keyframes_[queue.front()].id;
    queue.pop_front();
    step_keyframe(id, /*whole_view=*/true);
    ++stats.steps;
    if (after_step) after_step(id);
  }
  return stats;
}

}  // namespace chungs
