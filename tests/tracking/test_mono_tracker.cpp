// Monocular tracking end to end (issue 25): a synthetic street and the KITTI excerpt through the left camera
// only, with Sim(3)-aligned ATE, and a sequence that goes blank in the middle and must start a new map segment.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "chungs/datasets/mono_view.hpp"
#include "chungs/eval/trajectory_metrics.hpp"
#include "chungs/synth/street_dataset.hpp"
#include "tracking/tracking_test_util.hpp"

namespace chungs::tracking {
namespace {

std::unique_ptr<Dataset> street(size_t frames) {
  synth::StreetDatasetOptions o;
  o.street.length_m = 200;
  o.street.seed = 1;
  o.width = 620;
  o.height = 188;
  o.max_frames = frames;
  return with_input_mode(std::make_unique<synth::StreetDataset>(o), InputMode::Mono);
}

// Frames [from, to) of another dataset replaced by a flat gray image: nothing to track there.
class BlankStretch : public Dataset {
 public:
  BlankStretch(std::unique_ptr<Dataset> inner, size_t from, size_t to) : inner_(std::move(inner)), from_(from), to_(to) {}
  const DatasetInfo& info() const override { return inner_->info(); }
  Frame frame(size_t i) const override {
    Frame f = inner_->frame(i);
    if (i >= from_ && i < to_) f.left = Image8(f.left.width(), f.left.height(), f.left.channels(), 128);
    return f;
  }
  double timestamp(size_t i) const override { return inner_->timestamp(i); }
  std::optional<SE3> gt_pose(size_t i) const override { return inner_->gt_pose(i); }

 private:
  std::unique_ptr<Dataset> inner_;
  size_t from_, to_;
};

double sim3_ate(const Trajectory& gt, const Trajectory& est) {
  return compute_ate(gt, est, {Alignment::Sim3, 0.02}).stats.rmse;
}

TEST(MonoTracker, InputModeDropsRightImageAndDepth) {
  auto ds = street(2);
  EXPECT_FALSE(ds->info().has_right);
  EXPECT_FALSE(ds->info().has_depth);
  const Frame f = ds->frame(0);
  EXPECT_FALSE(f.right.has_value());
  EXPECT_FALSE(f.depth.has_value());
  EXPECT_EQ(f.baseline, 0);
  EXPECT_TRUE(f.gt_pose.has_value());
  EXPECT_THROW(parse_input_mode("stereo"), Error);
}

TEST(MonoTracker, SyntheticStreetWithinSim3Bound) {
  // The street's first 42 m are straight. Its first corner (a tight 90 degree turn at a metre per frame) is
  // where one camera at 620x188 may lose the map, and whether it does varies with the order of floating-point
  // sums in the multithreaded solvers: bench/README.md measures whole routes, this test the straight part.
  auto ds = street(42);
  TrackerOptions opt;
  opt.loop_closure = false;  // no loop to close
  VisualTracker tracker(opt);
  // The scale convention, checked the moment the map starts: median depth of the first keyframe = 1.
  for (size_t i = 0; tracker.map().keyframes() < 2 && i < 10; ++i) tracker.track(ds->frame(i));
  ASSERT_EQ(tracker.map().keyframes(), 2u);
  std::vector<double> z;
  const SE3 T0 = tracker.map().pose(0).inverse();
  for (long pid : tracker.map().kf(0).points)
    if (pid >= 0) z.push_back((T0 * tracker.map().point(pid)->pos).z());
  ASSERT_GE(z.size(), 50u);
  std::nth_element(z.begin(), z.begin() + long(z.size() / 2), z.end());
  EXPECT_NEAR(z[z.size() / 2], 1.0, 1e-9);

  VisualTracker fresh(opt);
  const auto s = test::run_tracker(*ds, fresh);
  // Only the first frame: it waits for the second view before the map (and its pose) exists.
  EXPECT_EQ(s.lost, 1u);
  EXPECT_EQ(fresh.timings().map_segments, 1u);
  ASSERT_EQ(s.est.size(), s.gt.size());
  const double path = s.gt.path_length();
  const double ate = sim3_ate(s.gt, s.est);
  RecordProperty("sim3_ate_m", std::to_string(ate));
  EXPECT_LT(ate, 0.01 * path) << "Sim(3) ATE " << ate << " m over " << path << " m";
  EXPECT_NE(fresh.describe().find("monocular"), std::string::npos);
}

TEST(MonoTracker, BlankStretchStartsNewSegmentAndTrackingContinues) {
  // The street runs straight for its first 45 m (a frame a metre): the gap and the new segment lie on it.
  constexpr size_t kFrames = 42, kBlankFrom = 12, kBlankTo = 18;
  BlankStretch ds(street(kFrames), kBlankFrom, kBlankTo);
  TrackerOptions opt;
  opt.loop_closure = false;
  opt.mono_relocalise = false;  // the street ahead is new after the gap anyway; this tests the new segment
  VisualTracker tracker(opt);
  std::vector<TrackState> states;
  Trajectory gt_after;
  for (size_t i = 0; i < ds.size(); ++i) {
    const Frame f = ds.frame(i);
    states.push_back(tracker.track(f).state);
    tracker.take_map_operations();
  }
  for (size_t i = kBlankFrom; i < kBlankTo; ++i) EXPECT_EQ(states[i], TrackState::Lost) << "blank frame " << i;
  EXPECT_EQ(tracker.timings().reinitialisations, 1u);
  EXPECT_EQ(tracker.timings().map_segments, 2u);
  // Two frames after the gap make the new segment; from then on every frame is tracked.
  for (size_t i = kBlankTo + 3; i < kFrames; ++i) EXPECT_NE(states[i], TrackState::Lost) << "frame " << i;
  // The new segment on its own: a consistent trajectory (its own scale, so Sim(3)).
  const Trajectory est = tracker.trajectory();
  Trajectory gt_seg, est_seg;
  std::map<double, size_t> index_of;
  for (size_t i = 0; i < ds.size(); ++i) index_of[ds.timestamp(i)] = i;
  for (size_t k = 0; k < est.size(); ++k) {
    const size_t i = index_of.at(est.stamps[k]);
    if (i < kBlankTo + 3 || i >= kFrames) continue;
    est_seg.push_back(est.stamps[k], est.poses[k]);
    gt_seg.push_back(ds.timestamp(i), *ds.gt_pose(i));
  }
  ASSERT_GE(est_seg.size(), 18u);
  EXPECT_LT(sim3_ate(gt_seg, est_seg), 0.01 * gt_seg.path_length());
}

TEST(MonoTracker, KittiExcerptLeftCameraWithinSim3Bound) {
  const std::filesystem::path dir = CHUNGS_SHARED_DATA "/kitti_seq1";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << dir << " is missing: the KITTI excerpt test needs it";
  auto ds = with_input_mode(open_dataset("kitti:" + dir.string()), InputMode::Mono);
  TrackerOptions opt;
  VisualTracker tracker(opt);
  const auto s = test::run_tracker(*ds, tracker);
  EXPECT_EQ(s.lost, 1u);  // the first frame, before the second view starts the map
  const double path = s.gt.path_length();
  const double ate = sim3_ate(s.gt, s.est);
  EXPECT_LT(ate, 0.015 * path) << "Sim(3) ATE " << ate << " m over " << path << " m (issue 25's bar: 1.5 %)";
}

}  // namespace
}  // namespace chungs::tracking
