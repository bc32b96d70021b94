// Mapper::refine: the steps after the last frame, spread over the whole map by refinement_plan.hpp.
#include <algorithm>

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
  std::vector<size_t> pass;
  std::vector<std::vector<ChunkId>> upcoming;  // the chunks of the pass's views, culled when first needed
  for (const RefinementGroup& g : groups) {
    if (g.steps > 0) ++stats.groups;
    for (uint64_t left = g.steps; left > 0;) {
      pass = g.keyframes;
      std::shuffle(pass.begin(), pass.end(), rng_);
      const size_t take = size_t(std::min<uint64_t>(left, pass.size()));
      upcoming.assign(take, {});
      for (size_t i = 0; i < take; ++i) {
        residency_->advance_checkpoint();
        if (!residency_->all_resident()) {
          // This step's chunks first, then those of the next few: read in the background meanwhile. Each
          // view is culled once for this, when it first comes within reach.
          std::vector<ChunkId> wanted;
          for (size_t j = i; j < std::min(take, i + 1 + ahead); ++j) {
            if (upcoming[j].empty())
              upcoming[j] = visible_chunks(keyframes_[pass[j]].camera, keyframes_[pass[j]].pose);
            wanted.insert(wanted.end(), upcoming[j].begin(), upcoming[j].end());
          }
          residency_->prefetch(wanted);
        }
        // Images further ahead than chunks (they are small): a shuffled pass reads most keyframes from
        // disk. Farthest first, since the store serves its latest request first.
        for (size_t j = std::min(take, i + 1 + 4 * ahead); j-- > i + 1;)
          keyframe_store_->prefetch(keyframes_[pass[j]].id);
        step_keyframe(keyframes_[pass[i]].id, /*whole_view=*/true);
        ++stats.steps;
        if (after_step) after_step(keyframes_[pass[i]].id);
      }
      left -= take;
    }
  }
  return stats;
}

}  // namespace chungs
