// The mapping run behind `diskchungs run`: frames and poses in, a map folder out, with held-out
// evaluation, renders, a JSON report, a timeline CSV and a memory plot. Resumable after a crash.
#pragma once
#include <atomic>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "chungs/config/config.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/tracking/options.hpp"

namespace chungs {

class LearnedDepth;  // chungs/depth/learned_depth.hpp

struct RunOptions {
  std::string dataset;        // kind:path
  std::string poses = "gt";   // gt, a trajectory file (TUM or KITTI), or track (the visual tracker)
  std::filesystem::path out;  // map folder
  bool resume = false;        // continue the run in `out` from its last checkpoint
  Config config;
  size_t max_frames = 0;      // use only the first n frames (0: all)
  tracking::TrackerOptions tracker;  // poses = track
  bool evaluate = true;       // render and score held-out frames (and keyframes) at the end
  // config.mapper.mono_depth_model loaded by the caller (the CLI checks it before the folder is touched).
  std::shared_ptr<const LearnedDepth> mono_depth_model;
  // Set (Ctrl-C) to stop at the next frame or refinement step: the map is committed there and the
  // report holds only "interrupted" (next_frame, frames, keyframes, gaussians, refining); --resume goes on.
  const std::atomic<bool>* stop = nullptr;
};

// Runs (or resumes) the mapping and returns the report that it also writes to out/report.json.
nlohmann::json run_mapping(const RunOptions& options);
// The same on a dataset the caller opened (options.dataset only names it in the report).
nlohmann::json run_mapping(const RunOptions& options, const Dataset& dataset);

// Frame i is held out (never trained on) under the rule of MapperConfig::holdout_every.
bool is_held_out(size_t frame, int holdout_every);

}  // namespace chungs
