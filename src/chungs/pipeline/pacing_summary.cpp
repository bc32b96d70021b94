#include "chungs/pipeline/pacing_summary.hpp"

#include <algorithm>
#include <map>

namespace chungs {

PacingSummary pacing_summary(const std::vector<TimelineSample>& samples, uint64_t refinement_steps) {
  PacingSummary p;
  if (samples.empty()) return p;
  // A keyframe's sample is the first one showing its count; samples of pose updates repeat it.
  const TimelineSample* prev = nullptr;
  for (const auto& s : samples) {
    if (prev && s.keyframes == prev->keyframes + 1 && s.iterations >= prev->iterations)
      p.per_keyframe.emplace_back(prev->seconds, s.iterations - prev->iterations);
    if (!prev || s.keyframes != prev->keyframes) prev = &s;
  }
  // A run of one keyframe has no interval between two keyframes: it got every step of the mapping (a
  // camera that stood still; "0 steps per keyframe" was reported).
  if (samples.back().keyframes == 1 && samples.back().iterations >= refinement_steps) {
    const auto first = std::find_if(samples.begin(), samples.end(), [](const auto& s) { return s.keyframes == 1; });
    p.per_keyframe = {{first->seconds, samples.back().iterations - refinement_steps}};
  }
  p.keyframes = p.per_keyframe.size();
  std::map<long, std::pair<double, uint64_t>> minutes;  // minute -> (steps, keyframes)
  double sum = 0;
  for (const auto& [t, n] : p.per_keyframe) {
    sum += double(n);
    auto& m = minutes[long(t / 60.0)];
    m.first += double(n);
    ++m.second;
    if (t >= 60.0 && (p.steps_min_after_first_minute < 0 || int64_t(n) < p.steps_min_after_first_minute))
      p.steps_min_after_first_minute = int64_t(n);
  }
  if (p.keyframes) p.steps_mean = sum / double(p.keyframes);
  // The first minute (start-up) counts only when the run has no other.
  const bool skip_first = minutes.size() > 1 && minutes.begin()->first == 0;
  bool any = false;
  for (const auto& [minute, m] : minutes) {
    if (skip_first && minute == 0) continue;
    const double mean = m.first / double(m.second);
    p.steps_lowest_minute = any ? std::min(p.steps_lowest_minute, mean) : mean;
    any = true;
  }
  const TimelineSample& last = samples.back();
  p.dropped = last.dropped;
  p.path_m = last.path_m;
  p.checkpoint_share = last.seconds > 0 ? last.checkpoint_ms / 1000.0 / last.seconds : 0;
  p.sampled = last.sampled;
  p.pruned = last.pruned;
  if (last.path_m >= PacingSummary::kMinPathForRates_m) {
    p.sampled_per_100m = double(last.sampled) / last.path_m * 100.0;
    p.pruned_per_100m = double(last.pruned) / last.path_m * 100.0;
  }
  return p;
}

nlohmann::json PacingSummary::to_json() const {
  return {{"keyframes", keyframes},
          {"steps_per_keyframe_mean", steps_mean},
          {"steps_per_keyframe_lowest_minute", steps_lowest_minute},
          {"steps_per_keyframe_min_after_first_minute", steps_min_after_first_minute},
          {"dropped_keyframes", dropped},
          {"checkpoint_share", checkpoint_share},
          {"path_m", path_m},
          {"sampled", sampled},
          {"pruned", pruned},
          {"sampled_per_100m", sampled_per_100m},
          {"pruned_per_100m", pruned_per_100m}};
}

}  // namespace chungs
