// The RGB-D front end on a ray-cast synthetic room: a box with blocky textured walls, exact depth.
#include <gtest/gtest.h>

#include <cmath>

#include "tracking_test_util.hpp"

using namespace chungs;

namespace {

uint32_t hash2(int a, int b, uint32_t seed) {
  uint32_t h = uint32_t(a) * 73856093u ^ uint32_t(b) * 19349663u ^ seed * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  return h ^ (h >> 15);
}

// Intensity of a wall at wall coordinates (a, b): coarse blocks with finer blocks on top.
uint8_t texture(double a, double b, int wall) {
  int coarse = int(hash2(int(std::floor(a * 4)), int(std::floor(b * 4)), uint32_t(wall)) % 160);
  int fine = int(hash2(int(std::floor(a * 12)), int(std::floor(b * 12)), uint32_t(wall + 7)) % 90);
  return uint8_t(coarse + fine);
}

// Renders the room [-3,3] x [-1.5,1.5] x [-3,3] (y down) from camera-to-world pose T_wc.
void render(const Camera& cam, const SE3& T_wc, Image8& img, ImageF& depth) {
  img = Image8(cam.width, cam.height, 1);
  depth = ImageF(cam.width, cam.height, 1);
  const Eigen::Vector3d lo(-3, -1.5, -3), hi(3, 1.5, 3);
  const Eigen::Matrix3d R = T_wc.rotation();
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Eigen::Vector3d dc((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0);  // z = 1: t is the depth
      Eigen::Vector3d d = R * dc, o = T_wc.t;
      double best = 1e9;
      int wall = -1;
      for (int ax = 0; ax < 3; ++ax) {
        if (std::abs(d[ax]) < 1e-12) continue;
        double t = ((d[ax] > 0 ? hi[ax] : lo[ax]) - o[ax]) / d[ax];
        if (t > 0 && t < best) best = t, wall = ax * 2 + (d[ax] > 0);
      }
      Eigen::Vector3d p = o + best * d;
      const int ax = wall / 2;
      double a = p[(ax + 1) % 3], b = p[(ax + 2) % 3];
      img(x, y) = texture(a, b, wall);
      depth(x, y) = float(best);
    }
}

}  // namespace

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
    render(cam, *f.gt_pose, f.left, depth);
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
