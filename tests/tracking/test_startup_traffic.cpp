// Start-up with a lorry crossing close ahead (issue 23): on the synthetic street with startup=cross
// the lorry's poster livery holds most of the first frames' features while it drives across at
// 45 km/h. The first 10 frames must still give the camera's own motion: forwards about 1 m a frame
// (every displacement from frame 0 within 15 degrees and 15 % of the truth; today's tracker was off by
// up to 79 degrees, going sideways with the lorry).
#include <gtest/gtest.h>

#include "chungs/synth/street_dataset.hpp"
#include "tracking_test_util.hpp"

using namespace chungs;

namespace {

synth::StreetDatasetOptions crossing_start(uint64_t seed, bool turn) {
  synth::StreetDatasetOptions o;
  o.street.length_m = 40;
  o.street.seed = seed;
  o.street.startup_cross = true;
  o.street.start_turn = turn;
  o.width = 620;
  o.height = 188;
  o.max_frames = 10;
  return o;
}

// Every frame's displacement from frame 0, in frame 0's camera coordinates, against the truth's.
void expect_right_direction(uint64_t seed, bool turn) {
  const synth::StreetDataset ds(crossing_start(seed, turn));
  tracking::VisualTracker tracker;
  const auto s = test::run_tracker(ds, tracker);
  ASSERT_EQ(s.est.size(), 10u);
  const SE3 g0_inv = s.gt.poses[0].inverse(), e0_inv = s.est.poses[0].inverse();
  for (size_t k = 1; k < 10; ++k) {
    const Eigen::Vector3d g = (g0_inv * s.gt.poses[k]).t, e = (e0_inv * s.est.poses[k]).t;
    const double angle = std::acos(std::clamp(g.dot(e) / (g.norm() * e.norm() + 1e-12), -1.0, 1.0)) * 180 / M_PI;
    std::printf("seed %llu%s frame %zu: truth (%.2f, %.2f, %.2f) m, estimate (%.2f, %.2f, %.2f) m, %.1f deg apart\n",
                (unsigned long long)seed, turn ? " turn" : "", k, g.x(), g.y(), g.z(), e.x(), e.y(), e.z(), angle);
    EXPECT_GT(e.z(), 0.8 * g.z()) << "frame " << k << ": the estimate falls short of the forward motion";
    EXPECT_LT(angle, 15.0) << "frame " << k << ": direction of motion";
    EXPECT_NEAR(e.norm(), g.norm(), 0.15 * g.norm() + 0.05) << "frame " << k << ": distance from frame 0";
  }
  EXPECT_LT(test::ate_rmse(s.gt, s.est), 0.5);  // today: 0.96-1.30 m over these 10 frames
}

}  // namespace

TEST(StartupTraffic, CrossingLorryDoesNotReverseTheMotion) {
  for (uint64_t seed : {3, 5, 8}) expect_right_direction(seed, false);
}

TEST(StartupTraffic, CrossingLorryWhileTurningDoesNotReverseTheMotion) { expect_right_direction(5, true); }
