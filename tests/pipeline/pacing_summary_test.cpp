// Steps per keyframe, the worst minute, drops and per-distance rates read off a timeline.
#include "chungs/pipeline/pacing_summary.hpp"

#include <gtest/gtest.h>

namespace chungs {
namespace {

// Keyframe k is added at 1.5 k seconds and gets steps[k] steps before the next one.
std::vector<TimelineSample> run_with_steps(const std::vector<uint64_t>& steps) {
  std::vector<TimelineSample> s;
  uint64_t it = 0;
  for (size_t k = 0; k < steps.size(); ++k) {
    TimelineSample t;
    t.seconds = 1.5 * double(k);
    t.keyframes = k + 1;
    t.iterations = it;
    t.path_m = 2.0 * double(k);
    t.sampled = 500 * (k + 1);
    t.pruned = 200 * k;
    t.dropped = k / 10;
    t.checkpoint_ms = 3.0 * double(k);
    s.push_back(t);
    it += steps[k];
  }
  return s;
}

TEST(PacingSummary, StepsPerKeyframeMeanLowestMinuteAndLeastAfterTheFirstMinute) {
  // 120 keyframes over 180 s: 40 per minute. Minute 0 starves (2 steps), minute 1 gets 20, minute 2
  // gets 12 with one keyframe at 7.
  std::vector<uint64_t> steps(120, 20);
  for (size_t k = 0; k < 40; ++k) steps[k] = 2;
  for (size_t k = 80; k < 120; ++k) steps[k] = 12;
  steps[100] = 7;
  const PacingSummary p = pacing_summary(run_with_steps(steps));
  ASSERT_EQ(p.keyframes, 119u);  // the last keyframe's steps are not known yet
  double sum = 0;
  for (size_t k = 0; k < 119; ++k) sum += double(steps[k]);
  EXPECT_NEAR(p.steps_mean, sum / 119.0, 1e-9);
  EXPECT_NEAR(p.steps_lowest_minute, (12.0 * 38 + 7) / 39.0, 1e-9);  // the first minute does not count
  EXPECT_EQ(p.steps_min_after_first_minute, 7);
  EXPECT_EQ(p.dropped, 11u);
  EXPECT_NEAR(p.path_m, 238.0, 1e-9);
  EXPECT_NEAR(p.sampled_per_100m, 500.0 * 120 / 238.0 * 100, 1e-6);
  EXPECT_NEAR(p.pruned_per_100m, 200.0 * 119 / 238.0 * 100, 1e-6);
  EXPECT_EQ(p.sampled, 500u * 120);
  EXPECT_EQ(p.pruned, 200u * 119);
  EXPECT_NEAR(p.checkpoint_share, 3.0 * 119 / 1000.0 / (1.5 * 119), 1e-12);
  const auto j = p.to_json();
  EXPECT_EQ(j["steps_per_keyframe_min_after_first_minute"].get<int>(), 7);
}

TEST(PacingSummary, PoseUpdateSamplesBetweenKeyframesDoNotSplitTheirSteps) {
  std::vector<TimelineSample> s = run_with_steps({30, 30, 30, 30});
  TimelineSample update = s[1];  // a correction recorded after keyframe 2 got 10 of its 30 steps
  update.seconds += 0.5;
  update.iterations += 10;
  s.insert(s.begin() + 2, update);
  const PacingSummary p = pacing_summary(s);
  ASSERT_EQ(p.keyframes, 3u);
  for (const auto& [t, n] : p.per_keyframe) EXPECT_EQ(n, 30u);
  EXPECT_EQ(p.steps_lowest_minute, 30.0);  // a short run: its only minute counts
  EXPECT_EQ(p.steps_min_after_first_minute, -1);
}

TEST(PacingSummary, EmptyAndStillRuns) {
  EXPECT_EQ(pacing_summary({}).keyframes, 0u);
  std::vector<TimelineSample> s = run_with_steps({5, 5});
  for (auto& t : s) t.path_m = 0;
  const PacingSummary p = pacing_summary(s);
  EXPECT_EQ(p.sampled_per_100m, 0.0);
  EXPECT_EQ(p.steps_mean, 5.0);
  EXPECT_EQ(p.sampled, 1000u);
}

TEST(PacingSummary, ARunOfOneKeyframeGotEveryStepButTheRefinements) {
  // A camera that stood still made one keyframe: "0 steps per keyframe" was reported. Under fixed
  // pacing its sample shows its 30 steps; in real time it shows none, and the steps come between frames.
  for (const uint64_t at_keyframe : {30u, 0u}) {
    std::vector<TimelineSample> s = run_with_steps({0});
    s[0].iterations = at_keyframe;
    TimelineSample later = s[0];  // the last frame, after 120 refinement steps
    later.seconds += 4.0, later.iterations = 30 + 120;
    s.push_back(later);
    const PacingSummary p = pacing_summary(s, 120);
    ASSERT_EQ(p.keyframes, 1u);
    EXPECT_EQ(p.steps_mean, 30.0);
    EXPECT_EQ(p.steps_lowest_minute, 30.0);
    EXPECT_EQ(p.per_keyframe[0].first, s[0].seconds);
    // The same after frames without a pose, whose sample shows no keyframe and no steps.
    TimelineSample before = s[0];
    before.keyframes = 0, before.iterations = 0, before.seconds = 0;
    s.insert(s.begin(), before);
    EXPECT_EQ(pacing_summary(s, 120).keyframes, 1u);
    EXPECT_EQ(pacing_summary(s, 120).steps_mean, 30.0) << at_keyframe;
  }
}

TEST(PacingSummary, NoRatesPer100mBelowAChunkOfTravelOnlyTotals) {
  // A camera that barely moved (EuRoC's first seconds: under 3 mm) would give hundreds of millions per 100 m.
  std::vector<TimelineSample> s = run_with_steps({5, 5, 5});
  for (auto& t : s) t.path_m *= 0.001;
  PacingSummary p = pacing_summary(s);
  EXPECT_EQ(p.sampled_per_100m, 0.0);
  EXPECT_EQ(p.pruned_per_100m, 0.0);
  EXPECT_EQ(p.to_json()["sampled"].get<uint64_t>(), 1500u);
  EXPECT_EQ(p.to_json()["pruned"].get<uint64_t>(), 400u);
  // Just past a chunk's length the rates are given.
  for (auto& t : s) t.path_m = t.path_m * 1000.0 * 2.6;  // 4 m steps: 10.4 m at the end
  p = pacing_summary(s);
  EXPECT_NEAR(p.sampled_per_100m, 1500.0 / 10.4 * 100, 1e-6);
}

}  // namespace
}  // namespace chungs
