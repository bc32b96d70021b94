// The tracker on the real data excerpts: KITTI stereo driving and an almost still EuRoC stereo window.
#include <gtest/gtest.h>

#include "test_support.hpp"
#include "tracking_test_util.hpp"

using namespace chungs;

TEST(StereoTracker, KittiExcerptAteBelow30cmWithoutLoss) {
  CHUNGS_REQUIRE_DATA("kitti_seq1");
  auto ds = open_dataset("kitti:" + test::shared_data("kitti_seq1").string());
  tracking::VisualTracker tracker;
  auto s = test::run_tracker(*ds, tracker);
  ASSERT_EQ(s.est.size(), ds->size());
  EXPECT_EQ(s.lost, 0u);
  const double ate = test::ate_rmse(s.gt, s.est);
  std::printf("KITTI excerpt: ATE %.4f m over %.1f m, %zu keyframes, %s\n", ate, s.gt.path_length(), s.keyframes,
              tracker.describe().c_str());
  EXPECT_LE(ate, 0.3);
  // The estimate covers the same distance (a stereo rig fixes the scale).
  EXPECT_NEAR(s.est.path_length(), s.gt.path_length(), 0.03 * s.gt.path_length());
}

TEST(StereoTracker, EurocStillWindowStaysWithin1cm) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  auto ds = open_dataset("euroc:" + test::shared_data("euroc_v101_micro").string());
  tracking::VisualTracker tracker;
  auto s = test::run_tracker(*ds, tracker);
  ASSERT_EQ(s.est.size(), ds->size());
  EXPECT_EQ(s.lost, 0u);
  double worst = 0;
  for (const auto& p : s.est.poses) worst = std::max(worst, (p.t - s.est.poses.front().t).norm());
  std::printf("EuRoC still window: largest distance from the start %.4f m, %s\n", worst, tracker.describe().c_str());
  EXPECT_LT(worst, 0.01);
}
