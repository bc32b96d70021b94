#include "map_flags.hpp"

#include <cmath>
#include <cstdint>

#include "chungs/config/presets.hpp"
#include "chungs/datasets/mono_view.hpp"
#include "chungs/depth/learned_depth.hpp"
#include "dataset_spec.hpp"
#include "flag_checks.hpp"

namespace chungs::app {

void add_map_flags(CLI::App& app, MapFlags& f) {
  app.add_option("--dataset", f.o.dataset, "dataset as kind:path (kitti, tum, replica, euroc, 3dmatch, synth-street, rosbag:FILE.bag?left=...)")
      ->required();
  app.add_option("--poses", f.o.poses, "gt (ground truth), a TUM/KITTI trajectory file, or track (the visual tracker)")
      ->capture_default_str();
  app.add_option("--config", f.config_file, "YAML configuration (see diskchungs info --config)");
  app.add_option("--preset", f.preset, "auto | outdoor | indoor: loss, fill depth and sky defaults")
      ->capture_default_str();
  app.add_option("--budget", f.budget, "resident Gaussians at most");
  app.add_option("--chunk-size", f.chunk_size, "chunk edge in metres (new maps)");
  app.add_option("--resolution", f.resolution, "image scale for mapping, (0, 1]");
  app.add_option("--final-iterations", f.final_iterations,
                 "refinement steps after the last frame, spread over every keyframe (default: one a keyframe; fixed pacing: at least 4 x --iterations)");
  app.add_option("--depth", f.depth, "auto | sensor | stereo | multiview (one camera: plane sweep against earlier keyframes; none means the same)");
  app.add_option("--fill-depth", f.fill_depth, "metres for sampled pixels without depth (sky); 0: skip them");
  app.add_option("--device", f.device, "auto | cuda | cpu: where the optimisation runs (auto: cuda when a GPU is usable)");
  app.add_flag("--no-ba", f.no_ba, "--poses track: no local bundle adjustment");
  app.add_flag("--no-loop", f.no_loop, "--poses track: no loop closure");
  app.add_option("--max-frames", f.max_frames, "use only the first n frames");
  app.add_option("--lpips-weights", f.lpips_weights,
                 "LPIPS weights (scripts/lpips_convert.py) to score the evaluation with; else no LPIPS");
  app.add_option("--mono-depth-model", f.mono_depth_model,
                 "ONNX depth model for monocular input (README: the contract; needs ONNX Runtime)");
  app.add_option("--input", f.input, "auto (all the dataset has) or mono (left camera only: no right image, no depth)")
      ->capture_default_str();
}

std::unique_ptr<Dataset> open_map_dataset(const MapFlags& f) {
  require_flag(f.input == "auto" || f.input == "mono", "--input", "auto or mono", f.input);
  return with_input_mode(open_dataset_spec(f.o.dataset), parse_input_mode(f.input));
}

RunOptions map_flags_options(const CLI::App& app, const MapFlags& f) {
  RunOptions o = f.o;
  Config& c = o.config;
  // The preset (the dataset's, or the one named) first; a configuration file then changes only
  // the keys it names. (It used to replace everything, so a file naming only the budget lost the
  // outdoor preset on KITTI without a word.)
  apply_preset(c, f.preset, o.dataset);
  if (!f.config_file.empty()) c = load_config(f.config_file, c);
  if (given(app, "--budget")) {
    const auto most = uint64_t(double(UINT32_MAX) / (1 + c.residency.pool_headroom));  // the pool's 32-bit slots
    require_flag(f.budget >= 1 && uint64_t(f.budget) <= most, "--budget", cat("1 to ", most, " Gaussians"), f.budget);
    c.residency.budget_gaussians = size_t(f.budget);
  }
  if (given(app, "--chunk-size")) {
    require_chunk_size_flag(f.chunk_size);
    c.store.chunk_size = f.chunk_size;
  }
  if (given(app, "--resolution")) {
    require_flag(std::isfinite(f.resolution) && f.resolution > 0 && f.resolution <= 1, "--resolution", "in (0, 1]",
                 f.resolution);
    c.mapper.resolution = f.resolution;
  }
  if (given(app, "--final-iterations")) {
    require_flag(f.final_iterations >= 0, "--final-iterations", "0 or more", f.final_iterations);
    c.mapper.final_iterations = f.final_iterations;
  }
  if (given(app, "--fill-depth")) {
    // Beyond the far plane its points would be culled from every view (and at 1e300 m outside any chunk).
    require_flag(std::isfinite(f.fill_depth) && f.fill_depth >= 0 && f.fill_depth <= c.culling.far, "--fill-depth",
                 cat("0 to culling.far (", c.culling.far, ") metres"), f.fill_depth);
    c.sampler.fill_depth = f.fill_depth;
  }
  if (given(app, "--max-frames")) {
    require_flag(f.max_frames >= 1, "--max-frames", "at least 1", f.max_frames);
    o.max_frames = size_t(f.max_frames);
  }
  // Given means typed, even empty: `--depth ""` is refused by validation, not ignored.
  if (given(app, "--depth")) c.mapper.depth = f.depth;
  if (given(app, "--device")) c.mapper.device = f.device;
  if (given(app, "--lpips-weights")) {
    require_flag(!f.lpips_weights.empty(), "--lpips-weights", "a weights file", "an empty path");
    c.mapper.lpips_weights = f.lpips_weights;
  }
  if (given(app, "--mono-depth-model")) {
    require_flag(!f.mono_depth_model.empty(), "--mono-depth-model", "an ONNX model file", "an empty path");
    c.mapper.mono_depth_model = f.mono_depth_model;
  }
  if (!c.mapper.mono_depth_model.empty()) {
    const char* source = given(app, "--mono-depth-model") ? "--mono-depth-model" : "mapper.mono_depth_model";
    try {
      o.mono_depth_model = LearnedDepth::load(c.mapper.mono_depth_model);
    } catch (const Error& e) {
      fail(source, ": ", e.what());
    }
  }
  o.tracker.local_ba = !f.no_ba;
  o.tracker.loop_closure = !f.no_loop;
  return o;
}

}  // namespace chungs::app
