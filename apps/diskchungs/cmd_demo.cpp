// `diskchungs demo`: the main job in one command. Renders the synthetic furnished room as an RGB-D
// sequence with ground truth, maps it on its ground-truth poses into a chunked map under a memory
// budget, exports the map as a 3DGS PLY and prints held-out quality, speed, memory and chunk I/O.
#include <chrono>
#include <cstdio>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/mapping/ply_export.hpp"
#include "chungs/mapping/run_pipeline.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/sequence.hpp"
#include "command.hpp"
#include "presets.hpp"

namespace chungs::app {
namespace {

namespace fs = std::filesystem;

struct DemoArgs {
  std::string out = "out/demo";
  size_t frames = 120, budget = 200'000;
  double resolution = 0.25, chunk_size = 2.0;
  int iterations = 10, final_iterations = 100;
  bool json = false;
};

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Outputs of an earlier demo are replaced; anything else in the way is left alone and refused.
void clear_previous(const fs::path& dir, const char* marker) {
  if (!fs::exists(dir)) return;
  if (!fs::exists(dir / marker))
    fail(dir.string(), " exists and is not from an earlier demo (no ", marker, "); choose another --out");
  fs::remove_all(dir);
}

int run_demo(const DemoArgs& a) {
  if (a.frames < 8) fail("--frames must be at least 8 (every 8th frame is held out for scoring), got ", a.frames);
  const fs::path out(a.out), room = out / "room", map = out / "map", ply = out / "map.ply";
  clear_previous(room, "rgb.txt");
  clear_previous(map, "manifest.txt");

  const auto t_synth = std::chrono::steady_clock::now();
  synth::RoomOptions ro;
  synth::MeshScene scene(synth::build_room(ro), synth::Environment::indoor());
  synth::SequenceOptions so;
  so.layout = synth::Layout::Tum;
  so.render.far = 30;
  log::info("demo: rendering the synthetic room, ", a.frames, " RGB-D frames at 640x480, into ", room.string());
  synth::render_sequence(scene, synth::room_trajectory(ro, a.frames), synth::tum_camera(640, 480), so, room);
  const double synth_s = since(t_synth);

  RunOptions o;
  o.dataset = "tum:" + room.string();
  o.poses = "gt";
  o.out = map;
  Config& c = o.config;
  apply_preset(c, "indoor", o.dataset);
  c.residency.budget_gaussians = a.budget;
  c.store.chunk_size = a.chunk_size;
  c.mapper.resolution = a.resolution;
  c.mapper.iterations_per_keyframe = a.iterations;
  c.mapper.final_iterations = a.final_iterations;
  c.validate();
  const nlohmann::json r = run_mapping(o);

  uint64_t exported = 0;
  {
    ChunkStore store(map, c.store);
    exported = export_ply(store, ply, PlySelection{});
  }
  if (a.json) {
    nlohmann::json j = r;
    j["demo"] = {{"synth_s", synth_s}, {"room", room.string()}, {"map", map.string()}, {"ply", ply.string()},
                 {"exported_gaussians", exported}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  const auto& g = r["gaussians"];
  const auto& io = r["chunk_io"];
  std::printf("\nDiskChunGS demo: synthetic room, %zu frames at %.0fx%.0f (sequence rendered in %.1f s)\n", a.frames,
              r["resolution"][0].get<double>(), r["resolution"][1].get<double>(), synth_s);
  if (r.contains("held_out"))
    std::printf("  held-out PSNR %.2f dB, SSIM %.4f over %zu never-trained frames (keyframes: %.2f dB)\n",
                r["held_out"]["mean_psnr"].get<double>(), r["held_out"]["mean_ssim"].get<double>(),
                r["held_out"]["count"].get<size_t>(), r["keyframes_eval"]["mean_psnr"].get<double>());
  std::printf("  mapping %.1f s, %.2f frames/s; %zu keyframes, %llu optimisation steps\n",
              r["time"]["mapping_s"].get<double>(), r["time"]["processing_fps"].get<double>(),
              r["keyframes"].get<size_t>(), (unsigned long long)r["iterations"].get<uint64_t>());
  std::printf("  Gaussians: %llu in %zu chunks, peak resident %llu (budget %llu)\n",
              (unsigned long long)g["total"].get<uint64_t>(), g["chunks"].get<size_t>(),
              (unsigned long long)g["peak_resident"].get<uint64_t>(), (unsigned long long)g["budget"].get<uint64_t>());
  std::printf("  chunk I/O: %llu loads (%.2f ms mean), %llu saves (%.2f ms mean), %.1f %% of the mapping time\n",
              (unsigned long long)io["loads"].get<uint64_t>(), io["mean_load_ms"].get<double>(),
              (unsigned long long)io["saves"].get<uint64_t>(), io["mean_save_ms"].get<double>(),
              100.0 * io["io_time_share"].get<double>());
  std::printf("  outputs: %s (sequence), %s (report.json, timeline.csv, memory.png, renders/), %s (%llu Gaussians)\n",
              room.string().c_str(), map.string().c_str(), ply.string().c_str(), (unsigned long long)exported);
  return 0;
}

const Command cmd{"demo", "synthetic room -> map under a budget -> PLY, with held-out PSNR/SSIM (about 30 s)",
                  [](CLI::App& app) {
  auto a = std::make_shared<DemoArgs>();
  app.add_option("--out", a->out, "output folder (room/, map/, map.ply; an earlier demo there is replaced)")
      ->capture_default_str();
  app.add_option("--frames", a->frames, "frames of the room sequence (600: one loop)")->capture_default_str();
  app.add_option("--resolution", a->resolution, "image scale for mapping, (0, 1]")->capture_default_str();
  app.add_option("--iterations", a->iterations, "optimisation steps per keyframe")->capture_default_str();
  app.add_option("--final-iterations", a->final_iterations, "refinement steps after the last frame")
      ->capture_default_str();
  app.add_option("--budget", a->budget, "resident Gaussians at most")->capture_default_str();
  app.add_option("--chunk-size", a->chunk_size, "chunk edge in metres")->capture_default_str();
  app.add_flag("--json", a->json, "print the run's report (with the demo's paths) as JSON");
  return [a]() { return run_demo(*a); };
}};

}  // namespace
}  // namespace chungs::app
