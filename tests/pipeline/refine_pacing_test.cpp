// The refinement of measured depth (multiview.refine, on by default) runs on the optimiser's thread:
// `run` uses it under fixed pacing and skips it under a real-time intake, where its time would be
// taken from the map's steps.
#include <gtest/gtest.h>

#include "pipeline/street_run.hpp"

namespace chungs {
namespace {

nlohmann::json map_short_street(const std::string& pacing) {
  return test::map_test_street(30, 160, 48, 7, [&](Config& c) {
    c.mapper.pacing = pacing;
    c.mapper.speed = 8;  // anytime: the 3 s drive arrives in under half a second
    c.mapper.iterations_per_keyframe = 2;
    EXPECT_TRUE(c.multiview.refine);  // the default
  });
}

TEST(RefinePacing, FixedPacingRefinesTheStereoDepthAndAnytimeDoesNot) {
  const nlohmann::json fixed = map_short_street("fixed");
  ASSERT_TRUE(fixed.contains("depth_refinement")) << fixed.dump();
  EXPECT_GT(fixed["depth_refinement"]["samplings"].get<uint64_t>(), 0u);
  const nlohmann::json anytime = map_short_street("anytime");
  EXPECT_FALSE(anytime.contains("depth_refinement")) << anytime["depth_refinement"].dump();
  EXPECT_GT(anytime["keyframes"].get<uint64_t>(), 0u);
}

}  // namespace
}  // namespace chungs
