// Loop closure end to end: VisualTracker on RGB-D frames rendered in memory along a circle that comes back to
// its start, so place recognition, verification, the pose graph and the map operation for the mapper all run
// on what the front end built, not on hand-made keyframes. At 160x120 with 1 % depth noise the open-loop drift is
// about 1.7 % of the path; the closure must cut the keyframes' error by 25 % and end within 2 % of the path.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "raycast_room.hpp"
#include "tracking_test_util.hpp"

using namespace chungs;

namespace {

// Camera-to-world pose on a circle of radius 1 m about the room centre at angle `a`, looking outward and
// slightly up and down, so one turn sees every wall once and then the first wall again.
SE3 circle_pose(double a) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.08 * std::sin(3 * a), Eigen::Vector3d::UnitX()));
  return SE3(q, Eigen::Vector3d(std::sin(a), 0.1 * std::sin(2 * a), std::cos(a)));
}

}  // namespace

TEST(LoopClosure, TrackerClosesRenderedRoomLoopAndReportsIt) {
  const Camera cam(160, 120, 125, 125, 79.5, 59.5);
  const int per_turn = 120, frames = per_turn + 15;
  // Depth noise (1 % of the depth, per pixel) makes the open-loop estimate drift, so the loop has something
  // to correct; the tracker is told the noise (1 % at 1.5 m, the typical wall distance, is k = 0.0067 / m).
  tracking::TrackerOptions opt;
  opt.rgbd_depth_noise = 0.0067;
  tracking::VisualTracker tracker(opt);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.f, 0.01f);
  Trajectory gt;
  std::vector<tracking::MapOperation> ops;
  std::unordered_map<long, size_t> kf_frame;
  size_t lost = 0;
  for (int i = 0; i < frames; ++i) {
    Frame f;
    f.index = size_t(i);
    f.timestamp = i / 30.0;
    f.camera = cam;
    f.gt_pose = circle_pose(2 * M_PI * i / per_turn);
    ImageF depth;
    test::render_room(cam, *f.gt_pose, f.left, depth);
    for (int y = 0; y < depth.height(); ++y)
      for (int x = 0; x < depth.width(); ++x) depth(x, y) *= 1.f + noise(rng);
    f.depth = std::move(depth);
    lost += tracker.track(f).state == tracking::TrackState::Lost;
    gt.push_back(f.timestamp, *f.gt_pose);
    for (auto& op : tracker.take_map_operations()) {
      if (op.kind == tracking::MapOperation::Kind::NewKeyframe) kf_frame[op.keyframe.id] = op.keyframe.frame_index;
      ops.push_back(std::move(op));
    }
  }
  EXPECT_EQ(lost, 0u);
  const tracking::LoopEvent* loop = nullptr;
  for (const auto& op : ops)
    if (op.kind == tracking::MapOperation::Kind::LoopClosure) {
      // Every loop must be a true revisit: the two keyframes' ground-truth positions are close.
      const size_t fq = kf_frame.at(op.loop.query), fm = kf_frame.at(op.loop.match);
      EXPECT_LT((gt.poses[fq].t - gt.poses[fm].t).norm(), 0.6) << "false loop: frame " << fq << " vs " << fm;
      if (fq + 20 >= size_t(per_turn) && fm < 20) loop = &op.loop;
    }
  ASSERT_NE(loop, nullptr) << "the return to the start was not closed";
  // The event carries what the mapper needs: both poses of every moved keyframe and the junction.
  ASSERT_FALSE(loop->new_poses.empty());
  ASSERT_EQ(loop->old_poses.size(), loop->new_poses.size());
  // Every keyframe announced before the loop (culled ones included: they follow their parents) is listed once,
  // under the id it was announced with.
  std::unordered_map<long, int> listed;
  for (size_t i = 0; i < loop->new_poses.size(); ++i) {
    EXPECT_EQ(loop->new_poses[i].first, loop->old_poses[i].first);
    ++listed[loop->new_poses[i].first];
  }
  for (const auto& [id, frame] : kf_frame)
    if (id <= loop->query) EXPECT_EQ(listed[id], 1) << "keyframe " << id << " (frame " << frame << ")";
  EXPECT_NE(std::find(loop->junction.begin(), loop->junction.end(), loop->query), loop->junction.end());
  EXPECT_NE(std::find(loop->junction.begin(), loop->junction.end(), loop->match), loop->junction.end());
  double moved = 0;
  for (size_t i = 0; i < loop->new_poses.size(); ++i)
    moved = std::max(moved, (loop->new_poses[i].second.t - loop->old_poses[i].second.t).norm());
  EXPECT_GT(moved, 0.0);
  // The correction brings the keyframes closer to the ground truth than they were before it.
  Trajectory kf_gt, kf_old, kf_new;
  for (size_t i = 0; i < loop->new_poses.size(); ++i) {
    const size_t fr = kf_frame.at(loop->new_poses[i].first);
    kf_gt.push_back(double(fr), gt.poses[fr]);
    kf_old.push_back(double(fr), loop->old_poses[i].second);
    kf_new.push_back(double(fr), loop->new_poses[i].second);
  }
  const double before = test::ate_rmse(kf_gt, kf_old), after = test::ate_rmse(kf_gt, kf_new);
  const Trajectory est = tracker.trajectory();
  ASSERT_EQ(est.size(), gt.size());
  const double ate = test::ate_rmse(gt, est), path = gt.path_length();
  std::printf("rendered RGB-D loop: keyframe ATE %.4f m before the closure, %.4f m after; frames %.4f m over %.2f m "
              "(%.2f %%), largest correction %.3f m, %s\n",
              before, after, ate, path, 100 * ate / path, moved, tracker.describe().c_str());
  EXPECT_LT(after, 0.75 * before);
  // With the depth row weighted by the stated noise the whole run ends within 2 % of the path (it was 5-8 %
  // when depth weighed 10x too little or a negative virtual right column counted as none).
  EXPECT_LT(ate, 0.02 * path);
}
