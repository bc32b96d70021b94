// Whether the optimiser kept up with the intake, read off a run's timeline: steps each keyframe got
// (on average, in the worst minute, the least any got after the first minute), keyframes dropped
// because the intake ran ahead, the share of time checkpoints cost, and how fast the map grew and
// shrank per 100 m travelled. A starving run shows here before it shows in the renders.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "chungs/pipeline/timeline.hpp"

namespace chungs {

struct PacingSummary {
  uint64_t keyframes = 0;          // keyframes whose steps are known (each but the last)
  double steps_mean = 0;           // steps per keyframe
  double steps_lowest_minute = 0;  // mean steps per keyframe in the worst minute (after the first, when the run has one)
  int64_t steps_min_after_first_minute = -1;  // least steps a keyframe added after 60 s got (-1: none)
  uint64_t dropped = 0;
  double checkpoint_share = 0;  // optimiser time in checkpoints / run time
  double path_m = 0;
  uint64_t sampled = 0, pruned = 0;  // Gaussians, over the whole run
  // 0 when the camera moved less than kMinPathForRates_m: a camera held still (EuRoC's first seconds)
  // would turn a few thousand Gaussians into hundreds of millions per 100 m.
  double sampled_per_100m = 0, pruned_per_100m = 0;
  static constexpr double kMinPathForRates_m = 10.0;  // one chunk
  std::vector<std::pair<double, uint64_t>> per_keyframe;  // (seconds at the keyframe, steps it got)
  nlohmann::json to_json() const;  // without per_keyframe
};

// Samples taken as keyframes are added (TimelineSample: keyframes, iterations); a keyframe's steps
// are the iterations between its sample and the next keyframe's. A run of one keyframe has no next:
// it got every step but the `refinement_steps` after the last frame (counted in the last samples).
PacingSummary pacing_summary(const std::vector<TimelineSample>& samples, uint64_t refinement_steps = 0);

}  // namespace chungs
