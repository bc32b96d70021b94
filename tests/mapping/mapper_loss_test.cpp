// A step's loss reaches its keyframe even though the mapper reads it only after the next step is
// queued (the GPU backend's loss is read late so the device never waits for the host): by each
// checkpoint every keyframe trained holds the loss of its latest step.
#include <gtest/gtest.h>

#include <cmath>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

TEST(MapperLoss, TheLastStepsLossReachesItsKeyframeAtTheCheckpoint) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  const test::WallSequence seq(1);
  Mapper m(dir / "map", c, false);
  const Frame f = seq.frame(0);
  m.add_keyframe(0, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  ASSERT_EQ(m.keyframes().size(), 1u);
  // One step: its loss is still in flight when step() returns; the checkpoint must read it.
  m.step();
  m.checkpoint(nlohmann::json::object());
  const double first = m.keyframes()[0].last_loss;
  EXPECT_TRUE(std::isfinite(first));
  EXPECT_GT(first, 0.0);
  for (int i = 0; i < 30; ++i) m.step();
  m.checkpoint(nlohmann::json::object());
  const double later = m.keyframes()[0].last_loss;
  EXPECT_GT(later, 0.0);
  EXPECT_LT(later, first) << "thirty steps on one view lower its loss";
}

}  // namespace
}  // namespace chungs
