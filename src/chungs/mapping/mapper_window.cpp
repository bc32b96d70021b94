// Mapper's training window (training_window.hpp): when the views of the selector's cell do not fit
// the budget together, the optimiser trains on the latest keyframe and the keyframes nearest a
// focus whose chunks fit beside it. The focus sweeps the cell's keyframes back and forth, a
// keyframe every `selector.sweep_steps` steps, so every keyframe of the cell keeps being trained
// while consecutive steps need nearly the same chunks: the few that enter the window are read
// ahead a step early instead of every step loading what the last one evicted.
#include <algorithm>
#include <unordered_set>

#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/training_window.hpp"

namespace chungs {

void Mapper::update_training_window() {
  if (keyframes_.empty()) return;
  const std::vector<uint32_t> cell = selector_.cell();
  // Only the cell's keyframes are remembered, so this cache stays as small as the cell.
  const std::unordered_set<uint32_t> in_cell(cell.begin(), cell.end());
  std::erase_if(view_chunks_, [&](const auto& kv) { return !in_cell.count(kv.first); });
  const uint32_t latest = selector_.latest();
  if (!in_cell.count(focus_)) focus_ = latest;
  const KeyframeRecord* focus = find_keyframe(focus_);
  if (!focus) return;
  std::vector<WindowKeyframe> keyframes;
  keyframes.reserve(cell.size());
  for (uint32_t id : cell) {
    const KeyframeRecord* k = find_keyframe(id);
    if (!k) continue;
    auto it = view_chunks_.find(id);
    // A view's chunks as of when it was first a candidate: chunks sampled later in front of it come
    // from newer keyframes, whose views hold them.
    if (it == view_chunks_.end()) {
      culler_->set_chunks_from(residency_->catalogue(), residency_->catalogue_version());
      it = view_chunks_.emplace(id, culler_->cull(k->camera, k->pose)).first;
    }
    // The latest keyframe comes first whatever the focus: new keyframes are trained at once.
    const double d = id == latest ? -1.0 : (k->pose.t - focus->pose.t).norm();
    keyframes.push_back({id, d, &it->second});
  }
  const uint64_t room = uint64_t(double(residency_->budget()) * config_.selector.budget_share);
  std::vector<uint32_t> window =
      fit_training_window(std::move(keyframes), [&](ChunkId c) { return residency_->count(c); }, room);
  if (window.size() < cell.size()) {
    selector_.restrict_to(std::move(window));
  } else {
    selector_.restrict_to({});
    focus_ = latest;
  }
}

void Mapper::sweep_training_window() {
  if (!selector_.restricted() || config_.selector.sweep_steps <= 0) return;
  if (iterations_ < focus_moved_at_ + uint64_t(config_.selector.sweep_steps)) return;
  focus_moved_at_ = iterations_;
  const std::vector<uint32_t> cell = selector_.cell();
  if (cell.size() < 2) return;
  const auto it = std::lower_bound(cell.begin(), cell.end(), focus_);
  long i = it == cell.end() || *it != focus_ ? long(cell.size()) - 1 : long(it - cell.begin());
  i += focus_step_;
  if (i < 0 || i >= long(cell.size())) {  // bounces at either end of the cell
    focus_step_ = -focus_step_;
    i = std::clamp(i + 2 * focus_step_, 0L, long(cell.size()) - 1);
  }
  focus_ = cell[size_t(i)];
  update_training_window();
}

}  // namespace chungs
