// Where the mapper's poses come from: the visual tracker on its own thread (`--poses track`), whose
// bundle-adjustment and loop-closure updates reach the map, and the applier that turns the tracker's
// keyframe ids and thresholds into Mapper::correct_poses calls.
#include <gtest/gtest.h>

#include <cmath>

#include "chungs/mapping/mapper.hpp"
#include "chungs/pipeline/pose_updates.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/sequence.hpp"
#include "chungs/synth/street_dataset.hpp"
#include "mapping/synthetic_sequence.hpp"
#include "test_support.hpp"
#include "mapping/tiny_config.hpp"

namespace chungs {
namespace {

Config small_config() {
  Config c = test::tiny_mapping_config();
  c.mapper.iterations_per_keyframe = 3;
  c.mapper.final_iterations = 0;
  c.mapper.checkpoint_every = 5;
  c.mapper.loop_refine_iterations = 5;
  c.mapper.device = "cpu";
  return c;
}

double angle_deg(const SE3& a, const SE3& b) { return (a.inverse() * b).angle() * 180.0 / M_PI; }

TEST(TrackedRun, MapsOnTheTrackersPosesAndKeyframes) {
  test::TempDir dir;
  synth::RoomOptions ro;
  synth::MeshScene scene(synth::build_room(ro), synth::Environment::indoor());
  const Camera cam = synth::tum_camera(160, 120);
  synth::SequenceOptions so;
  so.render.far = 30;
  synth::render_sequence(scene, synth::room_trajectory(ro, 48), cam, so, dir.path() / "room");

  RunOptions o;
  o.dataset = "tum:" + (dir.path() / "room").string();
  o.poses = "track";
  o.out = dir.path() / "map";
  o.config = small_config();
  o.evaluate = true;
  const nlohmann::json r = run_mapping(o);

  ASSERT_TRUE(r.contains("tracking"));
  const auto& t = r["tracking"];
  EXPECT_EQ(t["frames"].get<size_t>(), 48u);
  EXPECT_EQ(t["lost_frames"].get<size_t>(), 0u);
  ASSERT_TRUE(t.contains("ate"));
  // Reported against ground truth; the tracker's accuracy itself is tested in tests/tracking.
  EXPECT_EQ(t["ate"]["matched"].get<size_t>(), 48u);
  EXPECT_TRUE(std::isfinite(t["ate"]["rmse"].get<double>()));
  EXPECT_GT(r["held_out"]["mean_psnr"].get<double>(), 12.0);

  // The map's keyframes are the tracker's (minus held-out frames) at the tracker's final poses, up to
  // the thresholds below which bundle-adjustment nudges are not applied.
  Mapper reopened(o.out, o.config, true);
  const auto tracked = read_tum_trajectory(o.out / "trajectory.txt");
  ASSERT_EQ(tracked.size(), 48u);
  EXPECT_GT(reopened.keyframes().size(), 3u);
  EXPECT_LE(reopened.keyframes().size(), t["keyframes"].get<size_t>());
  for (const auto& k : reopened.keyframes()) {
    EXPECT_FALSE(is_held_out(k.frame, o.config.mapper.holdout_every)) << "frame " << k.frame;
    const SE3& est = tracked.poses[k.frame];
    const double dt = (est.t - k.pose.t).norm(), da = angle_deg(est, k.pose);
    EXPECT_TRUE(dt <= o.config.mapper.pose_update_min_translation + 1e-6 ||
                da <= o.config.mapper.pose_update_min_rotation_deg + 1e-6)
        << "keyframe " << k.id << " (frame " << k.frame << ") is " << dt << " m, " << da << " deg off";
  }
}

TEST(TrackedRun, TakesNoKeyframeFromADoubtfulPose) {
  // The lorry of startup=cross fills most of frames 3-7, where the tracker says its poses are doubtful
  // (tests/tracking/test_confidence.cpp): the run reports those frames and maps none of them.
  test::TempDir dir;
  synth::StreetDatasetOptions so;
  so.street.length_m = 100;
  so.street.seed = 3;
  so.street.startup_cross = true;
  so.width = 620;
  so.height = 188;
  so.max_frames = 12;
  const synth::StreetDataset ds(so);
  RunOptions o;
  o.dataset = "synth-street:startup=cross";
  o.poses = "track";
  o.out = dir.path() / "map";
  o.config = small_config();
  o.config.mapper.keyframe_every = 1;  // every confident frame a keyframe, so a doubtful one would be too
  o.config.mapper.holdout_every = 0;
  const nlohmann::json r = run_mapping(o, ds);
  const auto& t = r["tracking"];
  const auto doubtful = t["doubtful_frame_list"].get<std::vector<size_t>>();
  EXPECT_EQ(doubtful.size(), t["doubtful_frames"].get<size_t>());
  EXPECT_GE(doubtful.size(), 2u) << "the frames behind the lorry";
  Mapper reopened(o.out, o.config, true);
  EXPECT_GT(reopened.keyframes().size(), 2u);
  for (const auto& k : reopened.keyframes())
    EXPECT_EQ(std::count(doubtful.begin(), doubtful.end(), k.frame), 0) << "keyframe from doubtful frame " << k.frame;
  EXPECT_GE(t["doubtful_keyframes_not_mapped"].get<size_t>(), 1u);
}

TEST(TrackedRun, ResumeOfATrackedRunIsRefusedWithAReason) {
  test::TempDir dir;
  test::WallSequence seq(4);
  RunOptions o;
  o.dataset = "synthetic:wall";
  o.poses = "track";
  o.resume = true;
  o.out = dir.path() / "map";
  o.config = small_config();
  try {
    run_mapping(o, seq);
    FAIL() << "resume with --poses track was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--poses FILE"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(o.out));
}

TEST(PoseUpdateApplier, TranslatesIdsSkipsSmallMovesAndAppliesLoops) {
  test::TempDir dir;
  test::WallSequence seq(6);
  Config c = small_config();
  Mapper mapper(dir.path() / "map", c, false);
  PoseUpdateApplier applier(mapper, c.mapper);
  for (size_t i = 0; i < 4; ++i) {
    const Frame f = seq.frame(i);
    mapper.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    applier.added(long(100 + i), mapper.keyframes().back().id);
    mapper.step();
  }
  const SE3 before1 = mapper.keyframes()[1].pose, before2 = mapper.keyframes()[2].pose;
  const SE3 shift(Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.3, 1, 0.2).normalized())),
                  Eigen::Vector3d(0.15, -0.07, 0.04));

  // Bundle adjustment: keyframe 101 moves a lot, 102 by a millimetre, 999 is unknown (held out).
  PoseUpdate ba;
  ba.poses = {{101, shift * before1}, {102, SE3(before2.q, before2.t + Eigen::Vector3d(1e-3, 0, 0))},
              {999, shift}};
  const auto a = applier.apply({ba});
  EXPECT_EQ(a.keyframes_moved, 1u);
  EXPECT_FALSE(a.loop);
  EXPECT_LT((mapper.keyframes()[1].pose.t - (shift * before1).t).norm(), 1e-9);
  EXPECT_LT((mapper.keyframes()[2].pose.t - before2.t).norm(), 1e-12);

  // A loop closure moves keyframes 100 and 103 and refines the junction.
  PoseUpdate loop;
  loop.loop = true;
  loop.query = 103;
  loop.match = 100;
  loop.poses = {{100, shift * mapper.keyframes()[0].pose}, {103, shift * mapper.keyframes()[3].pose}};
  loop.junction = {100, 103};
  const uint64_t iterations = mapper.iterations();
  const auto b = applier.apply({loop});
  EXPECT_TRUE(b.loop);
  EXPECT_EQ(b.keyframes_moved, 2u);
  EXPECT_EQ(mapper.iterations(), iterations + uint64_t(c.mapper.loop_refine_iterations));
  const nlohmann::json rep = applier.report();
  EXPECT_EQ(rep["below_threshold"].get<size_t>(), 1u);
  EXPECT_EQ(rep["bundle_adjustment"]["keyframes_moved"].get<size_t>(), 1u);
  EXPECT_EQ(rep["loop_closures"]["count"].get<size_t>(), 1u);
  EXPECT_EQ(rep["loop_closures"]["events"][0]["query"].get<long>(), 103);
}

}  // namespace
}  // namespace chungs
