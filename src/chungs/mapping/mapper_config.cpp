#include "chungs/mapping/mapper_config.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

uint64_t MapperConfig::refinement_steps(size_t keyframes, size_t groups, uint64_t drive_steps) const {
  if (final_iterations >= 0) return uint64_t(final_iterations);
  // New Gaussians start nearly transparent and need about a hundred steps to take their colours; a
  // camera that stood still made one keyframe, which fixed pacing trained for one keyframe's steps
  // (EuRoC's first 4.7 s, --poses track: 14.3 dB held-out after 30 + 1 steps, 30.5 after 30 + 60,
  // 33.5 after 30 + 120). Under anytime pacing the intake's idle time already trains it, and steps
  // after the intake would lower the rate that keeps up with it.
  const uint64_t least = pacing == "fixed" ? 4 * uint64_t(std::max(iterations_per_keyframe, 0)) : 0;
  // Under a budget the groups are places of a few views each, and one step a keyframe visits each group
  // once or twice: what a map that fits the budget gets from its whole cell, views of a place trained in
  // turn with those of others, a budgeted map gets only from the rounds over the groups. So each group
  // gets at least refinement_group_steps, up to kMaxRefinementStepsPerKeyframe a keyframe and never more
  // than the drive's own steps (a run that chose few steps a keyframe for speed keeps that choice).
  // A drive of many steps a keyframe (anytime pacing at a slow intake) trained each place that much more
  // within its window, and needs as much more mixing: a group gets the drive's steps of a few keyframes,
  // and the refinement up to half the drive's steps.
  if (groups <= 1 || keyframes == 0) return std::max(uint64_t(keyframes), least);
  const bool drive_known = drive_steps != UINT64_MAX;
  const uint64_t per_keyframe = drive_known ? drive_steps / keyframes : 0;
  const uint64_t group = std::max(uint64_t(std::max(refinement_group_steps, 0)),
                                  refinement_group_steps > 0 ? kRefinementGroupDriveKeyframes * per_keyframe : 0);
  const uint64_t most = std::min(
      std::max(kMaxRefinementStepsPerKeyframe * uint64_t(keyframes), drive_known ? drive_steps / 2 : 0), drive_steps);
  const uint64_t mixed = std::min(uint64_t(groups) * group, most);
  return std::max({uint64_t(keyframes), least, mixed});
}

void MapperConfig::validate() const {
  if (pacing != "fixed" && pacing != "anytime")
    fail("mapper: pacing must be fixed or anytime, got '", pacing, "'");
  if (iterations_per_keyframe < 0)
    fail("mapper: iterations_per_keyframe must be >= 0, got ", iterations_per_keyframe);
  if (final_iterations < -1)
    fail("mapper: final_iterations must be >= 0, or -1 for one a keyframe, got ", final_iterations);
  if (refinement_rounds < 1 || refinement_rounds > 1000)
    fail("mapper: refinement_rounds must be in [1, 1000], got ", refinement_rounds);
  if (refinement_group_steps < 0 || refinement_group_steps > 1'000'000)
    fail("mapper: refinement_group_steps must be in [0, 1000000], got ", refinement_group_steps);
  if (refinement_min_visit_steps < 1 || refinement_min_visit_steps > 1'000'000)
    fail("mapper: refinement_min_visit_steps must be in [1, 1000000], got ", refinement_min_visit_steps);
  // An infinite speed would make every frame arrive at once: anytime pacing would train on none.
  if (!(speed >= kMinSpeed && speed <= kMaxSpeed))
    fail("mapper: speed must be a factor from ", kMinSpeed, " to ", kMaxSpeed, ", got ", speed);
  if (keyframe_every < 0) fail("mapper: keyframe_every must be >= 0, got ", keyframe_every);
  // Infinite ones passed, and all three at inf with keyframe_every 0 made a rule that never fires.
  for (auto [v, name] : {std::pair{keyframe_translation, "keyframe_translation"},
                         {keyframe_parallax, "keyframe_parallax"},
                         {keyframe_rotation_deg, "keyframe_rotation_deg"}})
    if (!(v >= 0) || !std::isfinite(v)) fail("mapper: ", name, " must be a finite number >= 0 (0: off), got ", v);
  if (keyframe_every == 0 && keyframe_translation == 0 && keyframe_parallax == 0 && keyframe_rotation_deg == 0)
    fail("mapper: no keyframe rule is on (keyframe_every, keyframe_translation, keyframe_parallax, "
         "keyframe_rotation_deg are all 0)");
  if (min_steps_per_keyframe < 0)
    fail("mapper: min_steps_per_keyframe must be >= 0, got ", min_steps_per_keyframe);
  if (holdout_every < 0 || holdout_every == 1)
    fail("mapper: holdout_every must be 0 or >= 2, got ", holdout_every);
  if (frame_lookahead < 0 || frame_lookahead > 64)
    fail("mapper: frame_lookahead must be in [0, 64], got ", frame_lookahead);
  if (read_ahead_steps < 1 || read_ahead_steps > 64)
    fail("mapper: read_ahead_steps must be in [1, 64], got ", read_ahead_steps);
  if (!(resolution > 0 && resolution <= 1)) fail("mapper: resolution must be in (0, 1], got ", resolution);
  if (depth != "auto" && depth != "sensor" && depth != "stereo" && depth != "multiview" && depth != "none")
    fail("mapper: depth must be auto, sensor, stereo, multiview or none, got '", depth, "'");
  if (checkpoint_every < 0) fail("mapper: checkpoint_every must be >= 0, got ", checkpoint_every);
  if (!(checkpoint_seconds >= 0) || !std::isfinite(checkpoint_seconds))
    fail("mapper: checkpoint_seconds must be >= 0, got ", checkpoint_seconds);
  if (!(checkpoint_max_share >= 0 && checkpoint_max_share <= 1))
    fail("mapper: checkpoint_max_share must be in [0, 1], got ", checkpoint_max_share);
  if (device != "auto" && device != "cuda" && device != "cpu")
    fail("mapper: device must be auto, cuda or cpu, got '", device, "'");
  if (gpu_keyframe_cache_mb < 0 || gpu_keyframe_cache_mb > (1 << 20))
    fail("mapper: gpu_keyframe_cache_mb must be in [0, 1048576], got ", gpu_keyframe_cache_mb);
  if (loop_refine_iterations < 0) fail("mapper: loop_refine_iterations must be >= 0, got ", loop_refine_iterations);
  if (!(pose_update_min_translation >= 0) || !std::isfinite(pose_update_min_translation))
    fail("mapper: pose_update_min_translation must be a finite number >= 0, got ", pose_update_min_translation);
  if (!(pose_update_min_rotation_deg >= 0) || !std::isfinite(pose_update_min_rotation_deg))
    fail("mapper: pose_update_min_rotation_deg must be a finite number >= 0, got ", pose_update_min_rotation_deg);
  if (eval_keyframe_stride < 0) fail("mapper: eval_keyframe_stride must be >= 0");
  // -1 saved nothing, as 0 does, instead of being refused.
  if (max_saved_renders < 0) fail("mapper: max_saved_renders must be >= 0, got ", max_saved_renders);
}

}  // namespace chungs
