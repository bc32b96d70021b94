// The optimiser's rates follow the steps keyframes get (AdamConfig::reference_steps): the configured
// steps under fixed pacing, the steps recent keyframes got in real time.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

Config rates_config(const std::string& pacing, int iterations, double reference_steps) {
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.mapper.pacing = pacing;
  c.mapper.iterations_per_keyframe = iterations;
  c.adam.reference_steps = reference_steps;
  return c;
}

// The colour render of frame 0 after one keyframe and `steps` steps.
std::vector<float> render_after(const Config& c, int steps) {
  test::TempDir dir;
  const test::WallSequence seq(1);
  Mapper m(dir / "map", c, false);
  const Frame f = seq.frame(0);
  m.add_keyframe(0, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  for (int i = 0; i < steps; ++i) m.step();
  const RenderOutput<float> r = m.render(f.camera, *f.gt_pose);
  return {r.rgb.data(), r.rgb.data() + r.rgb.size()};
}

TEST(MapperRates, FixedPacingScalesTheRatesByItsConfiguredSteps) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  Mapper m(dir / "map", rates_config("fixed", 120, 30), false);
  EXPECT_NEAR(m.rate_steps_factor(), 0.5, 1e-12);  // before any keyframe: known from the settings
  test::TempDir dir2;
  Mapper at30(dir2 / "map", rates_config("fixed", 30, 30), false);
  EXPECT_EQ(at30.rate_steps_factor(), 1.0);
}

float largest_difference(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  float d = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

TEST(MapperRates, StepsUseTheScaledRates) {
  log::set_level(log::Level::Error);
  // At 30 steps per keyframe the rule changes nothing: the same map with it off (up to the order in
  // which the backward's threads sum).
  const float same = largest_difference(render_after(rates_config("fixed", 30, 30), 3),
                                        render_after(rates_config("fixed", 30, 0), 3));
  EXPECT_LT(same, 1e-5f);
  // At 120 it halves three rates: a different map after the same steps.
  const float changed = largest_difference(render_after(rates_config("fixed", 120, 30), 3),
                                           render_after(rates_config("fixed", 120, 0), 3));
  EXPECT_GT(changed, 1e-3f);
  std::printf("largest colour difference after 3 steps: %.3g at 30 steps per keyframe, %.3g at 120\n", same,
              changed);
}

TEST(MapperRates, RealTimeFollowsTheStepsRecentKeyframesGot) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  const test::WallSequence seq(3);
  Mapper m(dir / "map", rates_config("anytime", 30, 30), false);
  EXPECT_EQ(m.rate_steps_factor(), 1.0) << "nothing measured yet";
  const auto add = [&](int k) {
    const Frame f = seq.frame(k);
    m.add_keyframe(uint64_t(k), f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  };
  add(0);
  for (int i = 0; i < 120; ++i) m.step();
  add(1);
  EXPECT_NEAR(m.rate_steps_factor(), 0.5, 1e-12) << "the first keyframe got 120 steps";
  for (int i = 0; i < 480; ++i) m.step();
  add(2);
  // Smoothed as the cap on new Gaussians smooths it: 0.75 * 120 + 0.25 * 480 = 210.
  EXPECT_NEAR(m.rate_steps_factor(), std::sqrt(30.0 / 210.0), 1e-12);
}

}  // namespace
}  // namespace chungs
