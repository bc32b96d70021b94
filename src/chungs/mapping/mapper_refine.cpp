// Mapper::refine: the steps after the last frame, spread over the whole map by refinement_plan.hpp.
#include <algorithm>
#include <deque>
#include <optional>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/refinement_plan.hpp"

namespace chungs {

std::vector<RefinementGroup> Mapper::plan_refinement_groups(uint64_t steps) {
  // 0.8: room for the chunks read ahead while a group's last steps still hold theirs.
  const uint64_t fit = std::max<uint64_t>(1, uint64_t(0.8 * double(residency_->budget())));
  PackedViews views;  // every view at once for the plan only (its memory grows with the drive: refinement_plan.hpp)
  for (const KeyframeRecord& kf : keyframes_) views.add(nearest_visible(kf.camera, kf.pose));
  return plan_refinement(views, fit, steps);
}

uint64_t Mapper::refinement_steps() {
  const MapperConfig& mc = config_.mapper;
  const size_t groups = mc.final_iterations < 0 && !keyframes_.empty() ? plan_refinement_groups(0).size() : 1;
  return mc.refinement_steps(keyframes_.size(), groups, iterations_);
}

Mapper::RefineStats Mapper::refine(uint64_t steps, const std::function<void(uint32_t)>& after_step,
                                   const std::function<bool()>& stop) {
  RefineStats stats;
  if (steps == 0) return stats;
  if (keyframes_.empty()) fail("mapper: refinement needs at least one keyframe");
  give_back_picks_ahead();  // drawn for step(): their chunks and images are not what comes next
  // The best-view masks keep far glimpses from painting a place while the window trains only some of
  // its views; the refinement trains all of them. Without the masks the 300 k cell on the 2 km street
  // scored 0.07-0.17 dB more on the GPU (bench/README.md, issue 19).
  refining_ = true;
  struct Leave {
    Mapper* m;
    ~Leave() { m->refining_ = false; }
  } leave{this};
  const std::vector<RefinementGroup> groups = plan_refinement_groups(steps);
  const size_t ahead = size_t(std::max(1, config_.mapper.read_ahead_steps));
  for (const RefinementGroup& g : groups) stats.groups += g.steps > 0;
  // The steps to come, a pass at a time, so that the read-ahead reaches into the next pass and the next
  // group: under a budget of about one view (100 k on the 2 km street) groups hold two views, and reads
  // that stopped at a group's end took the I/O wait of the run from 1.6 % to 2.65 % on the GPU.
  struct Queued {
    size_t keyframe;  // index
    // The nearest chunks of its view that fit the budget, culled when first prefetched: the map as it
    // is then, not as it was planned.
    std::optional<std::vector<ChunkId>> nearest;
  };
  std::deque<Queued> queue;
  const std::vector<RefinementVisit> visits =
      refinement_visits(groups, size_t(config_.mapper.refinement_rounds),
                        uint64_t(config_.mapper.refinement_min_visit_steps));
  std::vector<std::vector<size_t>> passes(groups.size());
  std::vector<size_t> cursor(groups.size(), 0);
  size_t visit = 0;
  uint64_t left = visits.empty() ? 0 : visits[0].steps;  // of the current visit
  const size_t reach = 1 + 4 * ahead;                    // this step and the images read ahead
  const auto refill = [&] {
    while (queue.size() < reach + 1) {
      while (left == 0 && ++visit < visits.size()) left = visits[visit].steps;
      if (left == 0) return;
      const size_t g = visits[visit].group;
      if (cursor[g] == passes[g].size()) {  // a fresh random order for each pass over the group
        passes[g] = groups[g].keyframes;
        std::shuffle(passes[g].begin(), passes[g].end(), rng_);
        cursor[g] = 0;
      }
      queue.push_back({passes[g][cursor[g]++], std::nullopt});
      --left;
    }
  };
  for (refill(); !queue.empty(); refill()) {
    if (stop && stop()) break;  // between steps: nothing pinned; chunks read ahead are kept as any
    residency_->advance_checkpoint();
    if (!residency_->all_resident()) {
      // This step's chunks first, then those of the next few: read in the background meanwhile.
      // (Naming every queued step's chunks, a few visits ahead, left as many loads waiting on the GPU:
      // bench/README.md, issue 19, 2026-12-04 afternoon.)
      std::vector<ChunkId> wanted;
      for (size_t j = 0; j < std::min(queue.size(), 1 + ahead); ++j) {
        std::optional<std::vector<ChunkId>>& nearest = queue[j].nearest;
        if (!nearest) {  // the nearest chunks that fit the budget are what a step loads
          const KeyframeRecord& kf = keyframes_[queue[j].keyframe];
          BudgetGroups fits = split_by_budget(nearest_visible(kf.camera, kf.pose), residency_->budget());
          nearest = fits.groups.empty() ? std::vector<ChunkId>{} : std::move(fits.groups[0]);
        }
        wanted.insert(wanted.end(), nearest->begin(), nearest->end());
      }
      residency_->prefetch(wanted);
    }
    // Images further ahead than chunks (they are small): a shuffled pass reads most keyframes from
    // disk. Farthest first, since the store serves its latest request first.
    for (size_t j = std::min(queue.size(), reach); j-- > 1;)
      keyframe_store_->prefetch(keyframes_[queue[j].keyframe].id);
    const uint32_t id = keyframes_[queue.front().keyframe].id;
    queue.pop_front();
    step_keyframe(id, /*whole_view=*/true);
    ++stats.steps;
    if (after_step) after_step(id);
  }
  return stats;
}

}  // namespace chungs
