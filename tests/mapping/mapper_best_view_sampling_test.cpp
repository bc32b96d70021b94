// A keyframe that sees a place on fewer than best_view_share of the blocks an earlier keyframe showed
// it on adds nothing there, with or without a training window: far glimpses had hazed streets mapped
// from near. A view of the place as large as the first one still samples it.
#include <gtest/gtest.h>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

TEST(MapperBestViewSampling, AFarGlimpseAddsNothingToChunksANearViewShowedLargerWithoutABudget) {
  log::set_level(log::Level::Error);
  for (double share : {0.5, 0.0}) {
    test::TempDir dir;
    Config c = test::tiny_mapping_config();
    c.mapper.device = "cpu";
    c.selector.best_view_share = share;
    const test::WallSequence near(2);                    // the wall 3 m ahead
    const test::WallSequence far(1, 64, 48, 0.08, 9.0);  // the same wall's texture, 9 m ahead ...
    Mapper m(dir / "map", c, false);
    Frame f = near.frame(0);
    const SampleStats first = m.add_keyframe(0, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    ASSERT_GT(first.kept, 0u);
    f = near.frame(1);
    const SampleStats beside = m.add_keyframe(1, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    EXPECT_EQ(beside.excluded, 0u) << "a view of the wall as near as the first one samples it";
    f = far.frame(0);
    const SE3 back(Eigen::Quaterniond::Identity(),
                   Eigen::Vector3d(0, 0, -6));  // ... seen from 6 m further back
    const SampleStats glimpse = m.add_keyframe(2, f.timestamp, f.left, f.depth, f.camera, back);
    EXPECT_FALSE(m.window_stats().narrowed) << "no budget, no window";
    if (share > 0)
      EXPECT_GT(glimpse.excluded, 0u) << "the near view's chunks are left out of the far one's samples";
    else
      EXPECT_EQ(glimpse.excluded, 0u) << "best_view_share 0 turns the rule off";
  }
}

}  // namespace
}  // namespace chungs
