// The mapping flags `run` and `pareto` share: the dataset and its poses, the preset and
// configuration file, and the settings every point of a Pareto run keeps (budget, resolution,
// device, ...). Each is checked where it is read, as flag_checks.hpp says.
#pragma once
#include <string>

#include "chungs/pipeline/run_pipeline.hpp"
#include "command.hpp"

namespace chungs::app {

struct MapFlags {
  RunOptions o;
  std::string config_file, preset = "auto";
  long long budget = 0, max_frames = 0;
  double chunk_size = 0, resolution = 0, fill_depth = 0;
  int final_iterations = 0;
  std::string depth, device, lpips_weights, mono_depth_model;
  std::string input = "auto";  // auto | mono (the dataset's left camera only)
  bool no_ba = false, no_loop = false;
};

// Adds --dataset (required), --poses, --config, --preset, --budget, --chunk-size, --resolution,
// --final-iterations, --depth, --fill-depth, --device, --no-ba, --no-loop, --max-frames,
// --lpips-weights, --mono-depth-model and --input to `app`, read into `f`.
void add_map_flags(CLI::App& app, MapFlags& f);

// The dataset named by f.o.dataset, read as --input says (checked here: the flag is named when wrong).
std::unique_ptr<Dataset> open_map_dataset(const MapFlags& f);

// f.o with its configuration made (the preset, then the file's keys, then the flags given) and the
// frame limit and tracker switches set; not yet validated, so a caller may change more first.
// Throws Error naming the flag of a value out of range. A monocular depth model (the flag or
// mapper.mono_depth_model) is loaded here, so a bad one is refused before any folder is touched.
RunOptions map_flags_options(const CLI::App& app, const MapFlags& f);

}  // namespace chungs::app
