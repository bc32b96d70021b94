// Mapper::update_training_window: narrows the selector's cell to the keyframes whose chunks fit
// the budget together (training_window.hpp).
#include <algorithm>
#include <unordered_set>

#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/training_window.hpp"

namespace chungs {

void Mapper::update_training_window() {
  if (keyframes_.empty()) return;
  const std::vector<uint32_t> cell = selector_.candidates();  // add() cleared the window
  // Only the cell's keyframes are remembered, so this cache stays as small as the cell.
  const std::unordered_set<uint32_t> in_cell(cell.begin(), cell.end());
  std::erase_if(view_chunks_, [&](const auto& kv) { return !in_cell.count(kv.first); });
  std::erase_if(coverage_, [&](const auto& kv) { return !in_cell.count(kv.first); });
  std::erase_if(core_chunks_, [&](const auto& kv) { return !in_cell.count(kv.first); });
  const Eigen::Vector3d at = keyframes_.back().pose.t;
  std::vector<WindowKeyframe> keyframes;
  keyframes.reserve(cell.size());
  for (uint32_t id : cell) {
    const KeyframeRecord* k = find_keyframe(id);
    if (!k) continue;
    auto it = view_chunks_.find(id);
    // A view's chunks as of when it was first a candidate: chunks sampled later in front of it come
    // from newer keyframes, which lie nearer the latest one and so enter the window first.
    if (it == view_chunks_.end()) {
      culler_->set_chunks_from(residency_->catalogue(), residency_->catalogue_version());
      it = view_chunks_.emplace(id, culler_->cull(k->camera, k->pose)).first;
    }
    // A keyframe back in the cell (the drive returning near streets it left) has no coverage until it
    // is picked: building it now would read its images on the optimiser's time (~480 reads a 2 km run).
    const std::vector<ChunkId>* core = config_.selector.core_share < 1 ? known_core(*k) : nullptr;
    keyframes.push_back({id, (k->pose.t - at).norm(), core ? core : &it->second});
  }
  const uint64_t room = uint64_t(double(residency_->budget()) * config_.selector.budget_share);
  std::vector<uint32_t> window =
      fit_training_window(keyframes, [&](ChunkId c) { return residency_->count(c); }, room);
  ++window_stats_.updates;
  if (window.size() < cell.size()) {
    const std::unordered_set<uint32_t> in_window(window.begin(), window.end());
    double reach = 0;
    for (const WindowKeyframe& k : keyframes)
      if (in_window.count(k.id)) reach = std::max(reach, k.distance);
    ++window_stats_.narrowed;
    window_stats_.keyframes += double(window.size());
    window_stats_.cell_keyframes += double(cell.size());
    window_stats_.reach_m += reach;
    selector_.restrict_to(std::move(window));
  }
}

const std::vector<ChunkId>* Mapper::known_core(const KeyframeRecord& kf) {
  if (!core_chunks_.count(kf.id) && !coverage_.count(kf.id)) return nullptr;
  return &core_chunks_of(kf);
}

const std::vector<ChunkId>& Mapper::core_chunks_of(const KeyframeRecord& kf) {
  auto it = core_chunks_.find(kf.id);
  if (it == core_chunks_.end()) it = core_chunks_.emplace(kf.id, coverage_of(kf).core(config_.selector.core_share)).first;
  return it->second;
}

std::vector<ChunkId> Mapper::chunks_shown_better(uint32_t keyframe, const ViewCoverage& coverage) const {
  const double share = config_.selector.best_view_share;
  if (!(share > 0) || !selector_.restricted()) return {};
  return best_views_.shown_better(keyframe, coverage, share, [&](uint32_t k) { return selector_.in_window(k); });
}

std::vector<ChunkId> Mapper::chunks_sampled_better(uint32_t keyframe, const ViewCoverage& coverage) const {
  // Unlike a step's mask, whether the better view is still trained does not matter: what a glimpse adds is
  // placed by the depth of far or grazing pixels, and the view that showed the chunk larger has sampled it.
  const double share = config_.selector.best_view_share;
  if (!(share > 0)) return {};
  return best_views_.shown_better(keyframe, coverage, share, [](uint32_t) { return false; });
}

}  // namespace chungs
