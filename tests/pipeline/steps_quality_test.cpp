// More steps per keyframe must not make a worse map (issue 20): a short synthetic street on the CPU
// mapped with the defaults (the outdoor preset, as `run` applies it) at 10 and 60 steps per keyframe,
// scored on the held-out frames. Under the paper's pruning by screen size (> 0.5 W) the longer run
// lost the parked cars that a close view saw large, and scored no better than the shorter one.
#include <gtest/gtest.h>

#include <cstdio>

#include "chungs/config/presets.hpp"
#include "pipeline/street_run.hpp"

namespace chungs {
namespace {

double held_out_psnr(int steps_per_keyframe) {
  // Of the seeds tried (1, 2, 3, 7), the one where the old rule's loss shows most at this length.
  const nlohmann::json report = test::map_test_street(60, 160, 48, 7, [&](Config& c) {
    apply_preset(c, "outdoor", "");  // the defaults, with the preset `run` picks for a street
    c.mapper.iterations_per_keyframe = steps_per_keyframe;
  });
  return report["held_out"]["mean_psnr"].get<double>();
}

TEST(StepsQuality, SixtyStepsPerKeyframeScoreBetterThanTen) {
  const double ten = held_out_psnr(10), sixty = held_out_psnr(60);
  std::printf("held-out PSNR: 10 steps/kf %.2f dB, 60 steps/kf %.2f dB (%+.2f)\n", ten, sixty, sixty - ten);
  // Runs of the same settings differ by up to ~0.7 dB here (the 10-step map most). With the chunk
  // threshold's floor of 50 (at 160x48), gains at 2 W were +0.39 to +1.11 dB over five runs, and at the
  // paper's 0.5 W -0.53: the longer run must score at least as well, as issue 20 asks.
  EXPECT_GE(sixty, ten);
}

}  // namespace
}  // namespace chungs
