#include "chungs/pipeline/pose_updates.hpp"

#include <cmath>

#include "chungs/common/log.hpp"

namespace chungs {

PoseUpdateApplier::Applied PoseUpdateApplier::apply(const std::vector<PoseUpdate>& updates) {
  Applied out;
  for (const PoseUpdate& u : updates) {
    std::vector<std::pair<uint32_t, SE3>> poses;
    for (const auto& [source, pose] : u.poses) {
      const auto it = ids_.find(source);
      if (it == ids_.end()) continue;  // a held-out frame's keyframe, or one the map never had
      const KeyframeRecord* rec = mapper_.find_keyframe(it->second);
      if (!rec) continue;
      const SE3 change = rec->pose.inverse() * pose;
      if (change.t.norm() < config_.pose_update_min_translation &&
          change.angle() * 180.0 / M_PI < config_.pose_update_min_rotation_deg) {
        ++skipped_small_;
        continue;
      }
      poses.emplace_back(it->second, pose);
    }
    std::vector<uint32_t> junction;
    for (long source : u.junction)
      if (const auto it = ids_.find(source); it != ids_.end()) junction.push_back(it->second);
    if (poses.empty() && !(u.loop && !junction.empty())) continue;
    const int refine = u.loop ? config_.loop_refine_iterations : 0;
    const PoseCorrectionStats st = mapper_.correct_poses(poses, u.loop ? junction : std::vector<uint32_t>{}, refine);
    out.keyframes_moved += poses.size();
    if (u.loop) {
      out.loop = true;
      ++loops_;
      loop_apply_ms_ += st.apply_ms;
      loop_refine_ms_ += st.refine_ms;
      nlohmann::json j = st.to_json();
      j["query"] = u.query;
      j["match"] = u.match;
      j["keyframes_in_event"] = u.poses.size();
      loops_json_.push_back(j);
      log::info("loop closure (tracker keyframes ", u.query, " -> ", u.match, "): ", poses.size(),
                " map keyframes moved, ", st.gaussians_moved, " Gaussians (", st.gaussians_changed_chunk,
                " changed chunk) in ", st.apply_ms, " ms, junction refined in ", st.refine_ms, " ms");
    } else {
      ++ba_updates_;
      ba_keyframes_ += poses.size();
      ba_ms_ += st.apply_ms;
    }
  }
  return out;
}

nlohmann::json PoseUpdateApplier::report() const {
  return {{"bundle_adjustment", {{"updates_applied", ba_updates_}, {"keyframes_moved", ba_keyframes_},
                                 {"apply_ms", ba_ms_}}},
          {"below_threshold", skipped_small_},
          {"loop_closures", {{"count", loops_}, {"apply_ms", loop_apply_ms_}, {"refine_ms", loop_refine_ms_},
                             {"events", loops_json_}}}};
}

}  // namespace chungs
