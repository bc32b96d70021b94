// The on-demand street dataset against the written sequence: the same frame bytes, poses, stamps
// and camera as `diskchungs synth street` writes and the KITTI reader reads back, whatever the
// order of requests and from several threads at once.
#include "chungs/synth/street_dataset.hpp"

#include <gtest/gtest.h>

#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/synth/sequence.hpp"
#include "test_support.hpp"

using namespace chungs;
using namespace chungs::synth;

namespace {
StreetDatasetOptions small_drive() {
  StreetDatasetOptions o;
  o.street.length_m = 200;
  o.street.seed = 5;
  o.width = 160;
  o.height = 48;
  return o;
}
}  // namespace

TEST(StreetDataset, FramesMatchTheWrittenSequenceInAnyOrderAndFromSeveralThreads) {
  test::TempDir dir;
  StreetDatasetOptions o = small_drive();
  // Frames spread over the route (a turn and the loop back included), written as the CLI does.
  const std::vector<size_t> picks = {0, 1, 57, 120, 199};
  const Trajectory full = street_trajectory(o.street);
  Trajectory some;
  for (size_t i : picks) some.push_back(full.stamps[i], full.poses[i]);
  {
    StreetWorld world(o.street);
    SequenceOptions so;
    so.layout = Layout::Kitti;
    so.baseline = kKittiBaseline;
    so.render.far = o.street.far;
    render_sequence(world, some, kitti_camera(o.width, o.height), so, dir.path());
  }
  const auto written = open_dataset("kitti:" + dir.path().string());
  const StreetDataset ds(o);
  ASSERT_EQ(ds.size(), full.size());
  EXPECT_EQ(ds.info().camera.width, written->info().camera.width);
  EXPECT_NEAR(ds.info().camera.fx, written->info().camera.fx, 1e-9);
  EXPECT_NEAR(ds.info().camera.cx, written->info().camera.cx, 1e-9);
  EXPECT_NEAR(ds.info().baseline, written->info().baseline, 1e-9);
  EXPECT_TRUE(ds.info().has_right && ds.info().has_gt && ds.info().color);

  auto check = [&](size_t k) {
    const Frame a = ds.frame(picks[k]);
    const Frame b = written->frame(k);
    EXPECT_EQ(a.index, picks[k]);
    EXPECT_EQ(a.left.vec(), b.left.vec()) << "left image of frame " << picks[k];
    ASSERT_TRUE(a.right && b.right);
    EXPECT_EQ(a.right->vec(), b.right->vec()) << "right image of frame " << picks[k];
    EXPECT_NEAR(a.timestamp, b.timestamp, 1e-6);
    EXPECT_LT((a.gt_pose->matrix() - b.gt_pose->matrix()).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_NEAR(a.baseline, b.baseline, 1e-9);
  };
  for (size_t k : {4, 0, 2, 1, 3}) check(k);  // out of order: the world cache must not matter
  std::vector<std::thread> threads;
  for (size_t k = 0; k < picks.size(); ++k) threads.emplace_back(check, k);
  for (auto& t : threads) t.join();
}

TEST(StreetDataset, MetadataWithoutRenderingAndErrorsNamingTheFrame) {
  StreetDatasetOptions o = small_drive();
  o.max_frames = 10;
  o.depth = true;
  const StreetDataset ds(o);
  EXPECT_EQ(ds.size(), 10u);
  EXPECT_DOUBLE_EQ(ds.timestamp(3), 0.3);
  EXPECT_TRUE(ds.gt_pose(9));
  const Frame f = ds.frame(2);
  ASSERT_TRUE(f.depth);
  EXPECT_EQ(f.depth->width(), 160);
  EXPECT_GT(f.depth->vec()[size_t(160 * 40 + 80)], 0.f);  // road ahead, below the horizon
  try {
    ds.frame(10);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 10"), std::string::npos) << e.what();
  }
  o.street.length_m = -1;
  EXPECT_THROW(StreetDataset{o}, Error);
  o = small_drive();
  o.width = 4;
  EXPECT_THROW(StreetDataset{o}, Error);
}
