// The RGB-D front end on a ray-cast synthetic room: a box with blocky textured walls, exact depth.
#include <gtest/gtest.h>

#include <cmath>

#include "raycast_room.hpp"
#include "tracking_test_util.hpp"

using namespace chungs;

TEST(RgbdTracker, FollowsSyntheticRoomWithExactDepth) {
  Camera cam(640, 480, 500, 500, 319.5, 239.5);
  tracking::VisualTracker tracker;
  Trajectory gt;
  size_t lost = 0, kfs = 0;
  for (int i = 0; i < 40; ++i) {
    Eigen::Matrix<double, 6, 1> xi;
    xi << 0.6 * std::sin(0.08 * i), 0.05 * std::sin(0.2 * i), -1.0 + 0.03 * i, 0.02 * std::sin(0.1 * i), 0.025 * i, 0;
    Frame f;
    f.index = size_t(i);
    f.timestamp = i / 30.0;
    f.camera = cam;
    f.gt_pose = SE3::exp(xi);
    ImageF depth;
    test::render_room(cam, *f.gt_pose, f.left, depth);
    f.depth = std::move(depth);
    auto r = tracker.track(f);
    lost += r.state == tracking::TrackState::Lost;
    kfs += r.keyframe;
    gt.push_back(f.timestamp, *f.gt_pose);
  }
  const Trajectory est = tracker.trajectory();
  ASSERT_EQ(est.size(), gt.size());
  EXPECT_EQ(lost, 0u);
  const double ate = test::ate_rmse(gt, est);
  std::printf("synthetic RGB-D room: ATE %.4f m over %.2f m, %zu keyframes\n", ate, gt.path_length(), kfs);
  EXPECT_LT(ate, 0.02);
  auto ops = tracker.take_map_operations();
  ASSERT_FALSE(ops.empty());
  EXPECT_EQ(ops.front().kind, tracking::MapOperation::Kind::NewKeyframe);
  EXPECT_GT(ops.front().keyframe.points.size(), 100u);
  EXPECT_EQ(ops.front().keyframe.points.size(), ops.front().keyframe.pixels.size());
}

TEST(VisualTracker, RejectsFrameWithoutDepthSource) {
  Frame f;
  f.left = Image8(64, 48, 1, 100);
  f.camera = Camera(64, 48, 50, 50, 32, 24);
  f.source = "mono.png";
  tracking::VisualTracker tracker;
  try {
    tracker.track(f);
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mono.png"), std::string::npos) << e.what();
  }
}
