// Mapper::correct_poses: the keyframe and selector side of a loop closure; the Gaussians are moved
// by apply_pose_correction (loop_corrector.cpp).
#include <algorithm>
#include <chrono>
#include <cmath>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"

namespace chungs {

PoseCorrectionStats Mapper::correct_poses(const std::vector<std::pair<uint32_t, SE3>>& new_poses,
                                          const std::vector<uint32_t>& junction, int refine_iterations) {
  if (refine_iterations < 0)
    fail("mapper: loop correction: refine_iterations must be >= 0, got ", refine_iterations);
  auto record_of = [&](uint32_t id, const char* what) -> KeyframeRecord& {
    KeyframeRecord* k = mutable_keyframe(id);
    if (!k) fail("mapper: loop correction: ", what, " keyframe ", id, " is not in the map");
    return *k;
  };
  PoseCorrection pc;
  pc.allow_batch = loop_batch_allowed_;
  const double o = config_.sampler.init_opacity;
  pc.reset_opacity_logit = float(std::log(o / (1 - o)));
  std::vector<uint32_t> involved;
  for (const auto& [id, pose] : new_poses) {
    const KeyframeRecord& k = record_of(id, "corrected");
    if (!pose.t.allFinite() || !pose.q.coeffs().allFinite())
      fail("mapper: loop correction: the new pose of keyframe ", id, " is not finite");
    if (!pc.delta.emplace(id, pose * k.pose.inverse()).second)
      fail("mapper: loop correction: keyframe ", id, " is corrected twice in one event");
    involved.push_back(id);
  }
  for (uint32_t id : junction) {
    record_of(id, "junction");
    if (pc.junction.insert(id).second) involved.push_back(id);
  }
  std::vector<ChunkId> candidates;
  if (keyframe_chunks_.complete()) {
    candidates = keyframe_chunks_.chunks_of(involved);
  } else {
    for (const auto& [c, n] : residency_->catalogue()) candidates.push_back(c);
    std::sort(candidates.begin(), candidates.end());
  }
  PoseCorrectionStats stats;
  if (!pc.delta.empty() || !pc.junction.empty())
    stats = apply_pose_correction(*residency_, store_->chunk_size(), pc, candidates, keyframe_chunks_);
  stats.keyframes = new_poses.size();

  if (!new_poses.empty()) give_back_picks_ahead();  // drawn with the views' old chunks
  // The keyframes follow; re-adding them to the selector keeps their usage but would make the
  // last one re-added define the training cell, so the newest keyframe is re-added last.
  for (const auto& [id, pose] : new_poses) {
    KeyframeRecord& k = record_of(id, "corrected");
    k.pose = pose;
    const KeyframeUsage u = selector_.usage(id);
    selector_.add(id, pose.t, u.uses, u.last_loss);
  }
  if (!new_poses.empty() && !keyframes_.empty()) {
    const KeyframeRecord& latest = keyframes_.back();
    const KeyframeUsage u = selector_.usage(latest.id);
    selector_.add(latest.id, latest.pose.t, u.uses, u.last_loss);
    view_chunks_.clear();  // the views moved
    stray_pool_.forget_all();  // its waiting picks were placed by poses that moved
    coverage_.clear();
    update_training_window();
  }

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<uint32_t> order(pc.junction.begin(), pc.junction.end());
  std::sort(order.begin(), order.end());
  for (int i = 0; i < refine_iterations && !keyframes_.empty(); ++i) {
    if (order.empty())
      step();
    else
      step_keyframe(order[size_t(i) % order.size()], /*whole_view=*/true);
  }
  stats.refine_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const std::string msg =
      cat("loop correction: ", stats.keyframes, " keyframes, ", stats.gaussians_moved, " Gaussians moved (",
          stats.gaussians_changed_chunk, " to another chunk) over ", stats.chunks_touched, " chunks (",
          stats.chunks_created, " new), ", stats.batch ? "batch" : "chunk by chunk", ", ", stats.apply_ms,
          " ms; ", stats.junction_gaussians, " junction Gaussians refined for ", refine_iterations,
          " steps in ", stats.refine_ms, " ms");
  // A loop closure (with a junction) is news; the small updates of local bundle adjustment are not.
  if (pc.junction.empty())
    log::debug(msg);
  else
    log::info(msg);
  return stats;
}

}  // namespace chungs
