// BestViews: each chunk's best view is the one that showed it on the most blocks; a view that shows
// it on under `share` of that is told to leave it alone only while the best view is out of the window.
#include "chungs/mapping/best_views.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

namespace chungs {
namespace {

// A camera on the z axis at `z`, looking along +z at a flat wall at z = 4: every pixel's surface is
// on the wall, so the chunks the view shows are those the wall's visible part crosses.
ViewCoverage wall_seen_from(double z) {
  const Camera camera{61, 37, 40.0, 40.0, 30.0, 18.0};
  const SE3 pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, z));
  return ViewCoverage(ImageF(61, 37, 1, float(4 - z)), camera, pose, 10.0, 0);
}

const ChunkId kCentre = chunk_id_of(Eigen::Vector3d(0, 0, 4), 10.0);

uint32_t blocks_of(const ViewCoverage& v, ChunkId c) {
  const auto it = std::find(v.chunks().begin(), v.chunks().end(), c);
  return it == v.chunks().end() ? 0 : v.blocks_per_chunk()[size_t(it - v.chunks().begin())];
}

TEST(BestViews, BlocksPerChunkCountEveryBlockOnce) {
  const ViewCoverage near = wall_seen_from(-1), far = wall_seen_from(-30);
  const uint32_t blocks = 16 * 10;  // 61x37 in 4x4 blocks
  ASSERT_EQ(near.chunks().size(), 1u);
  EXPECT_EQ(near.blocks_per_chunk(), std::vector<uint32_t>{blocks});
  ASSERT_GT(far.chunks().size(), 4u);
  const std::vector<uint32_t> n = far.blocks_per_chunk();
  EXPECT_EQ(std::accumulate(n.begin(), n.end(), 0u), blocks);
  // From 34 m a pixel spans 0.85 m of the wall: the block centres at u = 26, 30, 34 and v = 14, 18, 22
  // fall within 5 m of the axis, the next ones (6.8 m) do not.
  EXPECT_EQ(blocks_of(far, kCentre), 9u);
}

TEST(BestViews, AFarViewLeavesAloneWhatANearViewGoneFromTheWindowShowedLarger) {
  const ViewCoverage near = wall_seen_from(-1), far = wall_seen_from(-30);
  const auto none_in_window = [](uint32_t) { return false; };
  for (bool near_first : {true, false}) {
    BestViews best;
    if (near_first) best.note(1, near);
    best.note(2, far);
    if (!near_first) best.note(1, near);  // a later, larger view takes the chunk over
    EXPECT_EQ(best.shown_better(2, far, 0.06, none_in_window), std::vector<ChunkId>{kCentre});
    // Not while the near view can still be trained, nor below the share, nor for the best view itself.
    EXPECT_TRUE(best.shown_better(2, far, 0.5, [](uint32_t k) { return k == 1; }).empty());
    EXPECT_TRUE(best.shown_better(2, far, 0.05, none_in_window).empty());  // 9 of 160 blocks
    EXPECT_TRUE(best.shown_better(1, near, 1.0, none_in_window).empty());
    // The far view's other chunks are shown best by the far view itself.
    EXPECT_EQ(best.chunks(), far.chunks().size());
  }
}

TEST(BestViews, AViewNotNotedYetIsToldOnlyOfChunksOthersShowedLarger) {
  BestViews best;
  const ViewCoverage far = wall_seen_from(-30);
  EXPECT_TRUE(best.shown_better(7, far, 1.0, [](uint32_t) { return false; }).empty());
  best.note(3, wall_seen_from(-1));
  EXPECT_EQ(best.shown_better(7, far, 0.5, [](uint32_t) { return false; }), std::vector<ChunkId>{kCentre});
  best.clear();
  EXPECT_EQ(best.chunks(), 0u);
}

}  // namespace
}  // namespace chungs
