// A keyframe trained on again is sampled again where its render still lacks the image's detail
// (sampler.resample_every), so time spent on a place can add Gaussians as well as prune them.
#include <gtest/gtest.h>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

// Gaussians sampled after one keyframe (its first sampling capped low) and `steps` steps.
uint64_t sampled_after_steps(int resample_every, int steps) {
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.sampler.max_per_keyframe = 60;  // the first sampling leaves most of the detail to later ones
  c.sampler.min_per_chunk_per_100k_px = 0;
  c.sampler.min_per_chunk_floor = 0;
  c.sampler.resample_every = resample_every;
  const test::WallSequence seq(2);
  Mapper m(dir / "map", c, false);
  const Frame f = seq.frame(0);
  const SampleStats first = m.add_keyframe(0, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  EXPECT_GT(first.kept, 0u);
  EXPECT_LE(first.kept, 60u);
  for (int i = 0; i < steps; ++i) m.step();
  return m.sampled_total();
}

TEST(MapperResample, AKeyframeTrainedAgainIsSampledWhereItsRenderLacksDetail) {
  log::set_level(log::Level::Error);
  const uint64_t once = sampled_after_steps(0, 12);
  const uint64_t again = sampled_after_steps(4, 12);
  EXPECT_LE(once, 60u) << "without resampling, steps add nothing";
  EXPECT_GE(again, once + 60) << "three resamplings, each adding up to the cap";
  EXPECT_LE(again, once + 3 * 60);
}

// Keyframes arriving at least every `resample_every` steps are sampled on arrival; steps between
// them sample nothing more, so a fast intake's map is what it was without resampling.
TEST(MapperResample, KeyframesArrivingOftenLeaveTheSamplerToTheirArrival) {
  log::set_level(log::Level::Error);
  const auto sampled = [](int resample_every, int steps_between) {
    test::TempDir dir;
    Config c = test::tiny_mapping_config();
    c.mapper.device = "cpu";
    c.sampler.min_per_chunk_per_100k_px = 0;
    c.sampler.min_per_chunk_floor = 0;
    c.sampler.max_per_keyframe = 60;  // each sampling leaves detail for the next
    c.sampler.resample_every = resample_every;
    const test::WallSequence seq(3);
    Mapper m(dir / "map", c, false);
    for (int k = 0; k < 3; ++k) {
      const Frame f = seq.frame(k);
      m.add_keyframe(uint64_t(k), f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
      for (int i = 0; i < steps_between; ++i) m.step();
    }
    return m.sampled_total();
  };
  // Resampling can add here: with 4 steps between arrivals and an interval of 2, it does.
  EXPECT_GT(sampled(2, 4), sampled(0, 4));
  // An interval longer than the gap between arrivals: the same map as without resampling.
  EXPECT_EQ(sampled(5, 4), sampled(0, 4));
}

TEST(MapperResample, ANegativeIntervalIsRefused) {
  SamplerConfig s;
  s.resample_every = -1;
  EXPECT_THROW(s.validate(), Error);
}

}  // namespace
}  // namespace chungs
