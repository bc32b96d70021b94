// New chunks that one keyframe gives too few picks wait for later keyframes' picks in the same chunk
// (sampler.stray_wait_keyframes): a place entering the view a few pixels at a time still gets a chunk,
// and every chunk made holds at least the threshold.
#include <gtest/gtest.h>

#include <cmath>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

struct Outcome {
  uint64_t sampled = 0, chunks = 0, held_back = 0, released = 0;
};

// Four keyframes of the wall, no steps between them (chunk counts stay what sampling made).
Outcome map_wall(uint64_t least, int wait) {
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.sampler.min_per_chunk_per_100k_px = 0;
  // The floor is given for 10 m chunks and scaled to the chunk's face area: `least` on these chunks.
  const double side = c.store.chunk_size / SamplerConfig::kThresholdChunkM;
  c.sampler.min_per_chunk_floor = uint64_t(std::llround(double(least) / (side * side)));
  c.sampler.stray_wait_keyframes = wait;
  const test::WallSequence seq(4);
  Mapper m(dir / "map", c, false);
  for (int k = 0; k < 4; ++k) {
    const Frame f = seq.frame(size_t(k));
    m.add_keyframe(uint64_t(k), f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  }
  return {m.sampled_total(), m.chunk_count(), m.strays_held_back(), m.strays_released()};
}

TEST(MapperStrayPool, ChunksTooSmallForOneKeyframeAreMadeFromSeveral) {
  log::set_level(log::Level::Error);
  const Outcome free = map_wall(0, 0);
  ASSERT_GT(free.chunks, 2u);
  // The mean count per chunk: about half of one keyframe's chunks fall under it.
  const uint64_t least = std::max<uint64_t>(2, free.sampled / free.chunks);
  const Outcome dropped = map_wall(least, 0), pooled = map_wall(least, 5);
  EXPECT_GT(dropped.held_back, 0u);
  EXPECT_EQ(dropped.released, 0u);
  EXPECT_GT(pooled.released, 0u);
  EXPECT_GT(pooled.chunks, dropped.chunks);
  EXPECT_GT(pooled.sampled, dropped.sampled);
  // Every chunk made holds at least the threshold (later picks in a chunk that exists are any number).
  EXPECT_GE(pooled.sampled, least * pooled.chunks);
  EXPECT_GE(dropped.sampled, least * dropped.chunks);
}

// A loop correction moves the poses that placed the waiting picks: they are forgotten, not made later
// at the old places.
TEST(MapperStrayPool, ALoopCorrectionForgetsTheWaitingPicks) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.sampler.min_per_chunk_per_100k_px = 0;
  c.sampler.min_per_chunk_floor = 100000;  // nothing is ever made: every pick waits
  c.sampler.stray_wait_keyframes = 50;
  const test::WallSequence seq(2);
  Mapper m(dir / "map", c, false);
  for (int k = 0; k < 2; ++k) {
    const Frame f = seq.frame(size_t(k));
    m.add_keyframe(uint64_t(k), f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  }
  ASSERT_GT(m.strays_held_back(), 0u);
  EXPECT_EQ(m.strays_forgotten(), 0u);
  SE3 moved = m.keyframes()[1].pose;
  moved.t.x() += 0.05;
  m.correct_poses({{m.keyframes()[1].id, moved}}, {}, 0);
  EXPECT_EQ(m.strays_forgotten(), m.strays_held_back());
  EXPECT_EQ(m.sampled_total(), 0u);
}

TEST(MapperStrayPool, AWaitOutsideItsRangeIsRefused) {
  for (int bad : {-1, 1001}) {
    SamplerConfig s;
    s.stray_wait_keyframes = bad;
    EXPECT_THROW(s.validate(), std::exception) << bad;
  }
}

}  // namespace
}  // namespace chungs
