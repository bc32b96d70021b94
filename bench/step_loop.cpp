// The mapper's real step loop on a realistic map, phase by phase (issue 22): a synthetic street at
// KITTI's size (1241x376, outdoor settings as `run` picks them for synth-street, rendered depth) is
// mapped keyframe by keyframe, with a few steps after each, until the steps render about `--visible`
// Gaussians; then `--steps` steps are timed twice: plain (the figure that counts: nothing waits for
// the device but what the step itself waits for) and profiled (each phase bounded by a CUDA event,
// so the device is waited for at the end of every step).
//
//   bench_step_loop [--visible 200000] [--steps 500] [--device auto|cpu|cuda] [--width W --height H]
//                   [--density F] [--json FILE] [--folder DIR] [--map MAP] [--save-map DIR]
//                   [--segments N,N,...]
//
// --map: instead of growing a street, steps on a copy of a map folder that `diskchungs run` made with
// the outdoor preset (e.g. of ../shared/data/kitti_seq1), resumed as `run --resume` would.
// --segments: afterwards the same steps again, once per value of the GPU rasterizer's segment_entries
// (0: one block a tile; repeat values, e.g. 0,2048,0,2048, to see the drift of the map between them).
// --save-map: the grown street's map is also written to DIR (a checkpoint) before the timing, so that
// another build can be timed on the very same map with --map DIR: each build grows a different map
// (its kernels' rounding steers the sampler), and the maps differ by more than the kernels do.
//
// Phases: pick (next keyframe drawn, its view culled, its chunks read ahead), cull, pin, then the
// backend's targets, upload (slot list, pending chunk copies), forward, loss, sky, backward, adam,
// prune, then bookkeeping. "GPU idle" is the share of the step's wall time in which the device had no
// phase of the step to run: wall minus the device span of the backend's phases.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/config/config.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/synth/street_dataset.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

struct Options {
  size_t visible = 200000;
  int steps = 500, width = 1241, height = 376;
  double density = 0;  // 0: the sampler's default
  std::string device = "auto", json, folder, map, save_map;
  std::vector<int> segments;
};

double number(const char* flag, const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (!end || *end || !(v > 0)) fail(flag, " needs a positive number, got '", text, "'");
  return v;
}

std::vector<int> entry_counts(const std::string& text) {
  std::vector<int> out;
  std::stringstream list(text);
  for (std::string item; std::getline(list, item, ',');) {
    char* end = nullptr;
    const long n = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end || n < 0 || n > (1 << 24)) fail("--segments: not an entry count: '", item, "'");
    RasterConfig c;  // refused before the map is grown, not after
    c.segment_entries = int(n);
    c.validate();
    out.push_back(int(n));
  }
  if (out.empty()) fail("--segments: no entry count in '", text, "'");
  return out;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) fail("bench_step_loop: ", a, " needs a value (or is unknown)");
    const char* v = argv[++i];
    if (a == "--visible") o.visible = size_t(number("--visible", v));
    else if (a == "--steps") o.steps = int(number("--steps", v));
    else if (a == "--width") o.width = int(number("--width", v));
    else if (a == "--height") o.height = int(number("--height", v));
    else if (a == "--density") o.density = number("--density", v);
    else if (a == "--segments") o.segments = entry_counts(v);
    else if (a == "--device") o.device = v;
    else if (a == "--json") o.json = v;
    else if (a == "--folder") o.folder = v;
    else if (a == "--map") o.map = v;
    else if (a == "--save-map") o.save_map = v;
    else fail("bench_step_loop: unknown flag ", a);
  }
  return o;
}

// `run`'s outdoor preset (apps/diskchungs/presets.cpp), which it picks for synth-street.
Config outdoor(const Options& o) {
  Config c;
  c.loss = LossConfig::kitti();
  c.sampler.fill_depth = 80.0;
  c.sky.enabled = true;
  c.mapper.device = o.device;
  // The map is grown to the wanted size here, not paced: no cap on what a keyframe adds.
  c.sampler.new_per_step = 0;
  if (o.density > 0) c.sampler.density = o.density;
  c.residency.budget_gaussians = std::max<size_t>(c.residency.budget_gaussians, 2 * o.visible);
  return c;
}

struct Timed {
  double wall_ms = 0;
  double rendered = 0;  // mean Gaussians a step rendered
  Mapper::StepTimes mapper;
  StepPhaseTimes backend;
};

Timed time_steps(Mapper& m, int steps, bool profile) {
  m.set_step_profiling(profile);
  const Mapper::StepTimes before = m.step_times();
  const auto t0 = std::chrono::steady_clock::now();
  double rendered = 0;
  for (int i = 0; i < steps; ++i) rendered += double(m.step().rendered);
  Timed t;
  t.wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  t.rendered = rendered / steps;
  const Mapper::StepTimes& a = m.step_times();
  t.mapper = a;
  t.mapper.steps -= before.steps;
  t.mapper.total_ms -= before.total_ms, t.mapper.chunks_ms -= before.chunks_ms;
  t.mapper.backend_ms -= before.backend_ms, t.mapper.pick_ms -= before.pick_ms;
  t.mapper.cull_ms -= before.cull_ms, t.mapper.pin_ms -= before.pin_ms;
  t.mapper.bookkeeping_ms -= before.bookkeeping_ms, t.mapper.keyframe_load_ms -= before.keyframe_load_ms;
  t.mapper.slots_ms -= before.slots_ms, t.mapper.prune_ms -= before.prune_ms;
  t.backend = m.step_phase_times();
  m.set_step_profiling(false);
  return t;
}

nlohmann::json report(const Timed& t, int steps) {
  const double n = steps;
  nlohmann::json j = {{"ms_per_step", t.wall_ms / n},
                      {"steps_per_s", 1000.0 * n / t.wall_ms},
                      {"rendered_mean", t.rendered},
                      {"pick", t.mapper.pick_ms / n},
                      {"cull", t.mapper.cull_ms / n},
                      {"pin", t.mapper.pin_ms / n},
                      // Between the cull and the backend beside the pin: partial-view and trimmed-view
                      // masks, coverage, the slot list.
                      {"view", (t.mapper.chunks_ms - t.mapper.cull_ms - t.mapper.pin_ms) / n},
                      {"slot_list", t.mapper.slots_ms / n},
                      {"backend", t.mapper.backend_ms / n},
                      {"keyframe_load", t.mapper.keyframe_load_ms / n},
                      {"bookkeeping", t.mapper.bookkeeping_ms / n},
                      {"pruned_out", t.mapper.prune_ms / n}};
  if (t.backend.steps) {
    const double b = double(t.backend.steps);
    nlohmann::json host, device;
    for (int p = 0; p < StepPhaseTimes::count; ++p) {
      host[StepPhaseTimes::names[p]] = t.backend.host_ms[p] / b;
      device[StepPhaseTimes::names[p]] = t.backend.device_ms[p] / b;
    }
    j["backend_host"] = host;
    j["backend_device"] = device;
    nlohmann::json stages;
    for (int i = 0; i < StepPhaseTimes::stage_count; ++i)
      stages[StepPhaseTimes::stage_names[i]] = t.backend.stage_ms[i] / b;
    j["raster_stages"] = stages;
    j["tile_entries_mean"] = t.backend.tile_entries / b;
    j["largest_tile_mean"] = t.backend.largest_tile / b;
    j["top_percent_tiles_share"] = t.backend.top_percent_share / b;
    j["device_span"] = t.backend.device_span_ms / b;
    if (t.backend.device_span_ms > 0) j["gpu_idle_share"] = 1.0 - t.backend.device_span_ms / t.wall_ms;
  }
  return j;
}

void print(const char* title, const nlohmann::json& j) {
  std::printf("%s: %.3f ms per step (%.0f steps/s), %.0f Gaussians rendered per step\n", title,
              j["ms_per_step"].get<double>(), j["steps_per_s"].get<double>(), j["rendered_mean"].get<double>());
  std::printf(
      "  mapper   pick %.3f  cull %.3f  view %.3f (slot list %.3f)  pin %.3f  backend %.3f  bookkeeping %.3f "
      "(pruned leaving their chunks %.3f) ms\n",
      j["pick"].get<double>(), j["cull"].get<double>(), j["view"].get<double>(), j["slot_list"].get<double>(),
      j["pin"].get<double>(), j["backend"].get<double>(), j["bookkeeping"].get<double>(),
      j["pruned_out"].get<double>());
  if (!j.contains("backend_host")) return;
  std::printf("  %-10s %10s %10s\n", "phase", "host ms", "device ms");
  for (int p = 0; p < StepPhaseTimes::count; ++p)
    std::printf("  %-10s %10.3f %10.3f\n", StepPhaseTimes::names[p], j["backend_host"][StepPhaseTimes::names[p]].get<double>(),
                j["backend_device"][StepPhaseTimes::names[p]].get<double>());
  std::printf("  rasterizer (device ms):");
  for (int i = 0; i < StepPhaseTimes::stage_count; ++i)
    std::printf(" %s %.3f", StepPhaseTimes::stage_names[i],
                j["raster_stages"][StepPhaseTimes::stage_names[i]].get<double>());
  std::printf(
      "; %.2f M tile entries, the most crowded tile %.0f, the 1 %% most crowded tiles %.1f %% of them\n",
      j["tile_entries_mean"].get<double>() / 1e6, j["largest_tile_mean"].get<double>(),
      100 * j["top_percent_tiles_share"].get<double>());
  if (j.contains("gpu_idle_share"))
    std::printf("  device span %.3f ms, GPU idle %.1f %% of the step\n", j["device_span"].get<double>(),
                100.0 * j["gpu_idle_share"].get<double>());
}

int run(const Options& o) {
  log::set_level(log::Level::Warn);
  const fs::path folder = o.folder.empty() ? fs::temp_directory_path() / "bench_step_loop" : fs::path(o.folder);
  fs::remove_all(folder);
  synth::StreetDatasetOptions so;
  so.street.length_m = 1000;
  so.width = o.width, so.height = o.height;
  so.depth = true;
  const synth::StreetDataset ds(so);
  if (!o.map.empty()) {
    if (!fs::is_directory(o.map)) fail("--map: no map folder at ", o.map);
    fs::copy(o.map, folder, fs::copy_options::recursive);  // the user's folder is never written
  }
  auto owned = std::make_unique<Mapper>(folder, outdoor(o), !o.map.empty());
  Mapper& m = *owned;
  if (o.map.empty())
    std::printf("device %s, %dx%d, growing the map to ~%zu Gaussians per step\n", m.device().c_str(), o.width,
                o.height, o.visible);
  else
    std::printf("device %s, the map of %s\n", m.device().c_str(), o.map.c_str());
  // Keyframes every frame (about 1 m apart) with 10 steps each, until the steps render enough.
  double recent = 0;
  size_t frames = 0;
  for (size_t i = 0; o.map.empty() && i < ds.size() && recent < double(o.visible); ++i, ++frames) {
    const Frame f = ds.frame(i);
    m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    double sum = 0;
    for (int s = 0; s < 10; ++s) sum += double(m.step().rendered);
    recent = 0.7 * recent + 0.3 * (sum / 10);
    if (frames % 20 == 0)
      std::printf("  keyframe %zu: map %llu Gaussians, ~%.0f rendered per step\n", frames,
                  (unsigned long long)m.total_gaussians(), recent);
  }
  if (o.map.empty() && recent < 0.8 * double(o.visible))
    std::printf("note: the map stopped at ~%.0f Gaussians per step (raise --density)\n", recent);
  if (!o.map.empty()) {
    // A resumed map holds no chunk in memory: steps would load only their views' cores and mask the
    // pixels of the rest (selector.core_share), which a map grown in memory never does. Rendering
    // every keyframe's whole view once makes what fits the budget resident, as in the grown map.
    for (const KeyframeRecord& k : m.keyframes()) m.render(k.camera, k.pose);
  }
  std::printf("map: %zu keyframes, %llu Gaussians (%zu resident), %zu chunks\n", m.keyframes().size(),
              (unsigned long long)m.total_gaussians(), m.resident_gaussians(), m.chunk_count());
  if (!o.save_map.empty()) {
    if (!o.map.empty()) fail("--save-map: only a grown street is saved, not a --map");
    if (fs::exists(o.save_map)) fail("--save-map: ", o.save_map, " exists already (it is never overwritten)");
    m.checkpoint({});
    fs::copy(folder, o.save_map, fs::copy_options::recursive);
    std::printf("map saved to %s\n", o.save_map.c_str());
  }
  time_steps(m, std::min(o.steps, 100), false);  // warm-up: buffers at their size, caches filled
  if (!o.map.empty()) {
    // A resumed map's keyframes pay once for what a grown map did while growing (their images read back
    // and sent to the device, their coverage built): the first steps on each are not steady state.
    // The picks may cover only some of them (a window of a few keyframes when the budget is tight): stop
    // once 200 steps in a row found none new.
    std::unordered_set<uint32_t> seen;
    size_t extra = 0;
    for (size_t since_new = 0; seen.size() < m.keyframes().size() && since_new < 200; ++extra)
      since_new = seen.insert(m.step().keyframe).second ? 0 : since_new + 1;
    std::printf("warm-up: %zu more steps until %zu of %zu keyframes were trained once\n", extra, seen.size(),
                m.keyframes().size());
  }
  const nlohmann::json plain = report(time_steps(m, o.steps, false), o.steps);
  const nlohmann::json profiled = report(time_steps(m, o.steps, true), o.steps);
  print("plain", plain);
  print("profiled", profiled);
  nlohmann::json by_segment = nlohmann::json::array();
  for (int entries : o.segments) {
    m.set_raster_segment_entries(entries);
    const nlohmann::json p = report(time_steps(m, o.steps, false), o.steps);
    const nlohmann::json f = report(time_steps(m, o.steps, true), o.steps);
    std::printf("segment_entries %d:\n", entries);
    print("plain", p);
    print("profiled", f);
    by_segment.push_back({{"segment_entries", entries}, {"plain", p}, {"profiled", f}});
  }
  if (!o.json.empty()) {
    nlohmann::json out = {{"device", m.device()},
                          {"width", o.width},
                          {"height", o.height},
                          {"target_visible", o.visible},
                          {"keyframes", m.keyframes().size()},
                          {"map_gaussians", m.total_gaussians()},
                          {"plain", plain},
                          {"profiled", profiled},
                          {"by_segment_entries", by_segment}};
    std::ofstream(o.json) << out.dump(1) << "\n";
  }
  m.checkpoint({});  // a folder the mapper can close cleanly (it rolls back to the last checkpoint)
  owned.reset();
  fs::remove_all(folder);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_step_loop: %s\n", e.what());
    return 1;
  }
}
