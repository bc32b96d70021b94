// A keyframe whose depth map holds no valid pixel samples nothing, and the mapper counts it (the
// run's report names the count) instead of leaving an empty map unexplained.
#include <gtest/gtest.h>

#include <limits>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

TEST(MapperDepth, KeyframesWithoutAValidDepthPixelAreCountedAndSampleNothing) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  const test::WallSequence seq(3);
  Mapper m(dir / "map", c, false);
  Frame f = seq.frame(0);
  ASSERT_TRUE(f.depth);
  ImageF empty(f.depth->width(), f.depth->height(), 1, 0.f);
  empty.data()[5] = std::numeric_limits<float>::quiet_NaN();  // not a depth either
  const SampleStats none = m.add_keyframe(0, f.timestamp, f.left, empty, f.camera, *f.gt_pose);
  EXPECT_EQ(none.kept, 0u);
  EXPECT_EQ(m.total_gaussians(), 0u);
  EXPECT_EQ(m.keyframes_without_depth(), 1u);
  f = seq.frame(1);
  const SampleStats some = m.add_keyframe(1, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  EXPECT_GT(some.kept, 0u);
  EXPECT_EQ(m.keyframes_without_depth(), 1u) << "a keyframe with depth is not counted";
}

}  // namespace
}  // namespace chungs
