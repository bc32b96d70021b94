// A short synthetic street mapped on the CPU through run_mapping, for the pipeline tests: no renders
// saved, no keyframes scored, nothing written durably; `tune` sets what a test varies.
#pragma once
#include <functional>
#include <string>

#include "chungs/common/log.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/synth/street_dataset.hpp"
#include "test_support.hpp"

namespace chungs::test {

inline nlohmann::json map_test_street(int length_m, int width, int height, int seed,
                                      const std::function<void(Config&)>& tune) {
  log::set_level(log::Level::Warn);
  synth::StreetDatasetOptions so;
  so.street.length_m = length_m;
  so.street.seed = seed;
  so.width = width;
  so.height = height;
  const synth::StreetDataset street(so);
  TempDir dir;
  RunOptions o;
  o.dataset = "synth-street:length=" + std::to_string(length_m) + ",width=" + std::to_string(width) +
              ",height=" + std::to_string(height) + ",seed=" + std::to_string(seed);
  o.out = dir / "map";
  Config& c = o.config;
  c.mapper.device = "cpu";
  c.mapper.final_iterations = 0;
  c.mapper.eval_keyframe_stride = 0;
  c.mapper.max_saved_renders = 0;
  c.store.durable = false;
  c.keyframes.durable = false;
  tune(c);
  c.validate();
  return run_mapping(o, street);
}

}  // namespace chungs::test
