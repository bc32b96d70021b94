// `diskchungs demo`: the main job in one command. By default a synthetic stereo street whose route
// comes back to where it started, mapped on its ground-truth poses under a budget far below the map,
// so chunks leave memory and are loaded back when the car returns; or (--scene room) the furnished
// room as an RGB-D sequence. Exports the map as a 3DGS PLY and prints held-out quality, speed,
// memory and chunk I/O.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/config/presets.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/pipeline/ply_export.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/pipeline/run_report.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/sequence.hpp"
#include "command.hpp"
#include "dataset_spec.hpp"
#include "flag_checks.hpp"

namespace chungs::app {
namespace {

namespace fs = std::filesystem;

struct DemoArgs {
  std::string out = "out/demo", scene = "street";
  long long frames = 0, budget = 0;  // 0: the scene's default (signed: a typed -1 is refused, not wrapped)
  double length_m = 440, resolution = 0, chunk_size = 0;
  int iterations = 10, final_iterations = 100, seed = 15;
  bool json = false;
};

// The street: seed 15's route passes its start again after ~380 m; a budget of about a quarter of
// the map (~46 k Gaussians) holds one view's chunks (up to ~11 k), so the return loads evicted
// chunks back from disk.
constexpr size_t kStreetBudget = 12'000, kRoomBudget = 200'000, kRoomFrames = 120;

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The demo marks its --out folder: only there are map/, map.ply and room/ its own to replace. A map
// folder says nothing of who made it (any run writes manifest.txt), and a `run` map at OUT/map was
// replaced, and a map.ply beside it overwritten, without a word.
constexpr const char* kDemoMarker = "demo.txt";

// A demo's map from before the marker: its report names the demo's own dataset.
bool legacy_demo(const fs::path& out) {
  try {
    const std::string dataset = read_json_file(out / "map" / "report.json").value("dataset", std::string());
    return dataset.rfind("synth-street:", 0) == 0 ? dataset.find(",width=310,height=94,") != std::string::npos
                                                  : dataset == "tum:" + (out / "room").string();
  } catch (const std::exception&) {
    return false;
  }
}

void claim_out(const fs::path& out) {
  if (fs::exists(out) && !fs::is_directory(out)) fail("--out ", out.string(), " is not a folder");
  const bool marked = fs::exists(out / kDemoMarker) || legacy_demo(out);
  for (const char* name : {"map", "map.ply", "room"})
    if (fs::exists(out / name) && !marked)
      fail((out / name).string(), " exists and is not from an earlier demo (no ", (out / kDemoMarker).string(),
           "); choose another --out");
  std::error_code ec;
  if (fs::create_directories(out, ec), ec) fail("--out ", out.string(), ": cannot create the folder: ", ec.message());
  if (fs::exists(out / kDemoMarker)) return;
  std::ofstream f(out / kDemoMarker);
  f << "written by diskchungs demo: the next demo here replaces map/, map.ply and room/\n";
  if (!f.flush()) fail((out / kDemoMarker).string(), ": cannot be written");
}

// Outputs of an earlier demo are replaced; anything else in the way is left alone and refused.
void clear_previous(const fs::path& dir, const char* marker) {
  if (!fs::exists(dir)) return;
  if (!fs::exists(dir / marker))
    fail(dir.string(), " exists and is not from an earlier demo (no ", marker, "); choose another --out");
  fs::remove_all(dir);
}

int run_demo(const DemoArgs& a) {
  const bool street = a.scene == "street";
  if (!street && a.scene != "room") fail("--scene must be street or room, got '", a.scene, "'");
  const fs::path out(a.out), room = out / "room", map = out / "map", ply = out / "map.ply";
  RunOptions o;
  o.poses = "gt";
  o.out = map;
  Config& c = o.config;
  double synth_s = 0;
  std::unique_ptr<Dataset> dataset;
  if (street) {
    if (!(a.length_m >= 50 && a.length_m <= 100000))
      fail("--length-m must be in [50, 100000], got ", a.length_m);
    if (a.frames) fail("--frames is for --scene room; the street's length is --length-m");
    claim_out(out);
    clear_previous(map, "manifest.txt");
    o.dataset = cat("synth-street:length=", a.length_m, ",width=310,height=94,seed=", a.seed);
    apply_preset(c, "outdoor", o.dataset);
    c.residency.budget_gaussians = a.budget ? size_t(a.budget) : kStreetBudget;
    // Keyframe images are host memory the budget does not count (400 kept by default): a short demo
    // keeps fewer, so that memory levels off within its minute as it does on a long drive.
    c.keyframes.max_in_memory = 48;
    log::info("demo: a synthetic street of ", a.length_m, " m (stereo, rendered frame by frame) under a budget of ",
              c.residency.budget_gaussians, " Gaussians");
  } else {
    const size_t frames = a.frames ? size_t(a.frames) : kRoomFrames;
    if (frames < 8) fail("--frames must be at least 8 (every 8th frame is held out for scoring), got ", frames);
    claim_out(out);
    clear_previous(room, "rgb.txt");
    clear_previous(map, "manifest.txt");
    const auto t_synth = std::chrono::steady_clock::now();
    synth::RoomOptions ro;
    synth::MeshScene scene(synth::build_room(ro), synth::Environment::indoor());
    synth::SequenceOptions so;
    so.layout = synth::Layout::Tum;
    so.render.far = 30;
    log::info("demo: rendering the synthetic room, ", frames, " RGB-D frames at 640x480, into ", room.string());
    synth::render_sequence(scene, synth::room_trajectory(ro, frames), synth::tum_camera(640, 480), so, room);
    synth_s = since(t_synth);
    o.dataset = "tum:" + room.string();
    apply_preset(c, "indoor", o.dataset);
    c.residency.budget_gaussians = a.budget ? size_t(a.budget) : kRoomBudget;
    c.store.chunk_size = 2.0;
    c.mapper.resolution = 0.25;
  }
  if (a.chunk_size > 0) c.store.chunk_size = a.chunk_size;
  if (a.resolution > 0) c.mapper.resolution = a.resolution;
  c.mapper.iterations_per_keyframe = a.iterations;
  c.mapper.final_iterations = a.final_iterations;
  c.validate();
  dataset = open_dataset_spec(o.dataset);
  const nlohmann::json r = run_mapping(o, *dataset);

  uint64_t exported = 0;
  {
    ChunkStore store(map, c.store);
    exported = export_ply(store, ply, PlySelection{});
  }
  if (a.json) {
    nlohmann::json j = r;
    j["demo"] = {{"scene", a.scene}, {"synth_s", synth_s}, {"map", map.string()}, {"ply", ply.string()},
                 {"exported_gaussians", exported}};
    if (!street) j["demo"]["room"] = room.string();
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  const auto& g = r["gaussians"];
  const auto& io = r["chunk_io"];
  if (street)
    std::printf("\nDiskChunGS demo: synthetic street, %.0f m (%zu stereo frames at %.0fx%.0f)\n", a.length_m,
                r["frames"].get<size_t>(), r["resolution"][0].get<double>(), r["resolution"][1].get<double>());
  else
    std::printf("\nDiskChunGS demo: synthetic room, %zu frames at %.0fx%.0f (sequence rendered in %.1f s)\n",
                r["frames"].get<size_t>(), r["resolution"][0].get<double>(), r["resolution"][1].get<double>(), synth_s);
  if (r.contains("held_out"))
    std::printf("  held-out PSNR %.2f dB, SSIM %.4f over %zu never-trained frames (keyframes: %.2f dB)\n",
                r["held_out"]["mean_psnr"].get<double>(), r["held_out"]["mean_ssim"].get<double>(),
                r["held_out"]["count"].get<size_t>(), r["keyframes_eval"]["mean_psnr"].get<double>());
  std::printf("  mapping %.1f s, %.2f frames/s; %zu keyframes, %llu optimisation steps\n",
              r["time"]["mapping_s"].get<double>(), r["time"]["processing_fps"].get<double>(),
              r["keyframes"].get<size_t>(), (unsigned long long)r["iterations"].get<uint64_t>());
  const double total = double(g["total"].get<uint64_t>()), budget = double(g["budget"].get<uint64_t>());
  std::printf("  Gaussians: %.0f in %zu chunks (%.1fx the budget), peak resident %llu (budget %.0f)\n", total,
              g["chunks"].get<size_t>(), budget > 0 ? total / budget : 0.0,
              (unsigned long long)g["peak_resident"].get<uint64_t>(), budget);
  std::printf("  chunk I/O: %llu chunks evicted (%llu written), %llu loaded back from disk (%.2f ms mean); the "
              "optimiser waited on I/O %.1f %% of the time\n",
              (unsigned long long)(io["evictions_clean"].get<uint64_t>() + io["evictions_dirty"].get<uint64_t>()),
              (unsigned long long)io["saves"].get<uint64_t>(), (unsigned long long)io["loads"].get<uint64_t>(),
              io["mean_load_ms"].get<double>(), 100.0 * r["time"]["io_wait_share"].get<double>());
  if (r.contains("pacing"))
    if (const std::string w = training_window_line(r["pacing"]); !w.empty()) std::printf("  %s\n", w.c_str());
  if (r["memory"].contains("after_budget")) {
    const auto& f = r["memory"]["after_budget"]["rss"];
    std::printf("  host RSS once the budget was full: plateau %.0f MB, %.0f %% of samples within 5 %% (memory.png)\n",
                f["plateau_mb"].get<double>(), 100 * f["within_share"].get<double>());
  }
  if (!street) std::printf("  sequence: %s\n", room.string().c_str());
  std::printf("  outputs: %s (report.json, timeline.csv, memory.png, renders/), %s (%llu Gaussians)\n",
              map.string().c_str(), ply.string().c_str(), (unsigned long long)exported);
  return 0;
}

const Command cmd{"demo", "synthetic street (or room) -> map larger than its budget -> PLY, with held-out quality (about a minute)",
                  [](CLI::App& app) {
  auto a = std::make_shared<DemoArgs>();
  app.add_option("--out", a->out, "output folder (map/, map.ply, room/; an earlier demo there is replaced)")
      ->capture_default_str();
  app.add_option("--scene", a->scene, "street (stereo drive that returns to its start) | room (RGB-D)")
      ->capture_default_str();
  app.add_option("--length-m", a->length_m, "street: metres of route")->capture_default_str();
  app.add_option("--seed", a->seed, "street: which city and route")->capture_default_str();
  app.add_option("--frames", a->frames, "room: frames of the sequence (default 120; 600: one loop)");
  app.add_option("--resolution", a->resolution, "image scale for mapping, (0, 1] (room default 0.25)");
  app.add_option("--iterations", a->iterations, "optimisation steps per keyframe")->capture_default_str();
  app.add_option("--final-iterations", a->final_iterations, "refinement steps after the last frame, spread over every keyframe")
      ->capture_default_str();
  app.add_option("--budget", a->budget, "resident Gaussians at most (street default 12000, room 200000)");
  app.add_option("--chunk-size", a->chunk_size, "chunk edge in metres (street default 10, room 2)");
  app.add_flag("--json", a->json, "print the run's report (with the demo's paths) as JSON");
  return [a, &app]() {
    // 0 stands for "the scene's default" inside DemoArgs; typed on the command line it is refused.
    if (given(app, "--budget")) require_flag(a->budget >= 1, "--budget", "at least 1 Gaussian", a->budget);
    // 99999999999 frames grew to 2 GB before writing one; the room needs 8 (every 8th is held out).
    if (given(app, "--frames"))
      require_flag(a->frames >= 8 && uint64_t(a->frames) <= synth::kMaxFrames, "--frames",
                   cat("8 to ", synth::kMaxFrames), a->frames);
    // The street's own flags were taken and ignored with the room (--length-m nan ran).
    if (a->scene == "room")
      for (const char* flag : {"--length-m", "--seed"})
        if (given(app, flag)) fail(flag, " is for --scene street; the room has --frames");
    if (given(app, "--resolution"))
      require_flag(std::isfinite(a->resolution) && a->resolution > 0 && a->resolution <= 1, "--resolution",
                   "in (0, 1]", a->resolution);
    if (given(app, "--chunk-size")) require_chunk_size_flag(a->chunk_size);
    require_flag(a->seed >= 0, "--seed", "0 or more", a->seed);
    require_flag(a->iterations >= 0, "--iterations", "0 or more", a->iterations);
    require_flag(a->final_iterations >= 0, "--final-iterations", "0 or more", a->final_iterations);
    return run_demo(*a);
  };
}};

}  // namespace
}  // namespace chungs::app
