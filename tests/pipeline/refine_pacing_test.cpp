// The refinement of measured depth (multiview.refine, on by default) runs on the optimiser's thread:
// `run` uses it under fixed pacing and skips it under a real-time intake, where its time would be
// taken from the map's steps.
#include <gtest/gtest.h>

#include "chungs/common/log.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/synth/street_dataset.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

nlohmann::json map_short_street(const std::string& pacing) {
  log::set_level(log::Level::Warn);
  synth::StreetDatasetOptions so;
  so.street.length_m = 30;
  so.street.seed = 7;
  so.width = 160;
  so.height = 48;
  const synth::StreetDataset street(so);
  test::TempDir dir;
  RunOptions o;
  o.dataset = "synth-street:length=30,width=160,height=48,seed=7";
  o.out = dir / "map";
  Config& c = o.config;
  c.mapper.device = "cpu";
  c.mapper.pacing = pacing;
  c.mapper.speed = 8;  // anytime: the 3 s drive arrives in under half a second
  c.mapper.iterations_per_keyframe = 2;
  c.mapper.final_iterations = 0;
  c.mapper.eval_keyframe_stride = 0;
  c.mapper.max_saved_renders = 0;
  c.store.durable = false;
  c.keyframes.durable = false;
  c.validate();
  EXPECT_TRUE(c.multiview.refine);  // the default
  return run_mapping(o, street);
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
