// `diskchungs synth room|street|mesh|check-office0`: the synthetic sequence generator (the embedded
// default scene and the long-drive data), written in the TUM or KITTI layout the readers load.
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "chungs/common/log.hpp"
#include "chungs/synth/mesh_render.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/sequence.hpp"
#include "chungs/synth/street.hpp"
#include "command.hpp"
#include "flag_checks.hpp"

namespace chungs::app {
namespace {

struct SynthArgs {
  std::string out, layout = "tum", mesh, traj, intrinsics, data;
  long long frames = 300, every = 1, max_frames = 0;  // signed: a typed -1 is refused, not wrapped
  uint64_t seed = 1;
  int width = 0, height = 0;
  double length_m = 1000, baseline = 0.1, rate_hz = 30;
  bool json = false, no_depth = false;
};

void report(const synth::SequenceReport& r, const std::string& out) {
  std::printf("wrote %zu frames to %s in %.1f s (%.1f frames/s rendering), up to %zu triangles drawn\n", r.frames,
              out.c_str(), r.seconds, r.frames / std::max(r.render_seconds, 1e-9), r.max_triangles_drawn);
  // A mesh of no faces, or of faces with no area, gave a blank sequence with exit 0 and no word.
  if (r.max_triangles_drawn == 0)
    log::warn(out, ": no triangle was drawn in any frame; every image is background (an empty or degenerate mesh, "
              "or a trajectory that never looks at it)");
}

// The flags a scene was given, range-checked with the flag named before anything is rendered (a
// typed --frames -3 used to wrap to 2^64 - 3 and end, gigabytes later, in bad_alloc).
void check_flags(const CLI::App& s, const SynthArgs& a) {
  for (const auto& [flag, v] : {std::pair{"--width", a.width}, std::pair{"--height", a.height}})
    if (given(s, flag))
      require_flag(v >= 1 && v <= synth::kMaxImageSide, flag, cat("1 to ", synth::kMaxImageSide, " pixels"),
                   v);
  if (a.width > 0 && a.height > 0)
    require_flag(uint64_t(a.width) * uint64_t(a.height) <= kMaxImagePixels, "--width x --height",
                 cat("at most ", kMaxImagePixels, " pixels (what the dataset readers take)"),
                 cat(a.width, "x", a.height));
  require_flag(!a.out.empty(), "--out", "a folder", "an empty path");
  if (given(s, "--frames")) {
    if (s.get_name() == "room")
      require_flag(a.frames >= 1 && uint64_t(a.frames) <= synth::kMaxFrames, "--frames",
                   cat("1 to ", synth::kMaxFrames), a.frames);
    else
      require_flag(a.max_frames >= 0, "--frames", "0 (all) or more", a.max_frames);
  }
  if (given(s, "--baseline"))
    require_flag(std::isfinite(a.baseline) && a.baseline > 0, "--baseline", "a positive number of metres",
                 a.baseline);
  if (given(s, "--length-m"))
    require_flag(a.length_m > 0 && a.length_m <= synth::kMaxStreetLengthM, "--length-m",
                 cat("in (0, ", synth::kMaxStreetLengthM, "] metres"), a.length_m);
  if (given(s, "--every")) require_flag(a.every >= 1, "--every", "at least 1", a.every);
  // Frames are named by their stamps to the microsecond (TUM layout): above 1 MHz two frames would share a
  // file, and below a frame a million seconds the stamps outgrow their names.
  if (given(s, "--rate"))
    require_flag(std::isfinite(a.rate_hz) && a.rate_hz >= 1e-6 && a.rate_hz <= 1e6, "--rate",
                 "from 1e-06 to 1e+06 Hz", a.rate_hz);
}

int run_room(const SynthArgs& a) {
  synth::RoomOptions o;
  o.seed = a.seed;
  Camera cam = synth::tum_camera(a.width ? a.width : 640, a.height ? a.height : 480);
  synth::MeshScene scene(synth::build_room(o), synth::Environment::indoor());
  synth::SequenceOptions so;
  so.layout = synth::parse_layout(a.layout);
  so.baseline = a.baseline;
  so.kitti_depth = !a.no_depth;
  so.render.far = 30;
  report(synth::render_sequence(scene, synth::room_trajectory(o, size_t(a.frames)), cam, so, a.out), a.out);
  return 0;
}

int run_street(const SynthArgs& a) {
  synth::StreetOptions o;
  o.seed = a.seed;
  o.length_m = a.length_m;
  Camera cam = synth::kitti_camera(a.width ? a.width : 1241, a.height ? a.height : 376);
  synth::StreetWorld world(o);
  synth::SequenceOptions so;
  so.layout = synth::Layout::Kitti;
  so.baseline = synth::kKittiBaseline;
  so.kitti_depth = !a.no_depth;
  so.render.far = o.far;
  auto rep = synth::render_sequence(world, synth::street_trajectory(o, size_t(a.max_frames)), cam, so, a.out);
  report(rep, a.out);
  std::printf("street: %zu distinct blocks, %zu triangles over them, at most %zu held at once\n",
              world.distinct_blocks(), world.distinct_triangles(), rep.max_scene_triangles);
  return 0;
}

int run_mesh(const SynthArgs& a) {
  synth::MeshSequenceSpec s;
  s.mesh = a.mesh;
  s.traj = a.traj;
  s.out = a.out;
  s.camera = synth::parse_intrinsics(a.intrinsics);
  s.seq.layout = synth::parse_layout(a.layout);
  s.seq.baseline = a.baseline;
  s.seq.kitti_depth = !a.no_depth;
  s.every = size_t(a.every);
  s.max_frames = size_t(a.max_frames);
  s.rate_hz = a.rate_hz;
  report(synth::render_mesh_sequence(s), a.out);
  return 0;
}

int run_check(const SynthArgs& a) {
  auto c = synth::check_office0(a.data);
  if (a.json) {
    nlohmann::json j{{"median_abs_depth_diff_m", c.median_abs_diff}, {"mean_abs_depth_diff_m", c.mean_abs_diff},
                     {"valid_pixels", c.valid_pixels}, {"pixels", c.pixels}, {"render_seconds", c.render_seconds},
                     {"triangles", c.triangles}};
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("office0 pose 0: median |depth difference| %.4f m, mean %.4f m over %zu of %zu pixels "
                "(%zu triangles, render %.3f s)\n",
                c.median_abs_diff, c.mean_abs_diff, c.valid_pixels, c.pixels, c.triangles, c.render_seconds);
  }
  return 0;
}

const Command synth_cmd("synth", "render synthetic sequences (room, street, a mesh along a trajectory)", [](CLI::App& app) -> Action {
  auto a = std::make_shared<SynthArgs>();
  app.require_subcommand(1);
  auto size_opts = [a](CLI::App* s) {
    s->add_option("--width", a->width, "image width (default per scene)");
    s->add_option("--height", a->height, "image height (default per scene)");
    // A typed -1 is refused by main (number_flags.hpp), not wrapped to 2^64 - 1.
    s->add_option("--seed", a->seed, "random seed: same seed, same bytes");
    s->add_flag("--no-depth", a->no_depth, "KITTI layout: leave out depth/ (uint16, metres * 256)");
  };
  auto* room = app.add_subcommand("room", "furnished textured room, RGB-D (TUM layout, 640x480, 30 Hz)");
  room->add_option("--out", a->out, "output folder")->required();
  room->add_option("--frames", a->frames, "frames (one loop of the room is 600)")->capture_default_str();
  room->add_option("--layout", a->layout, "tum or kitti (stereo)")->capture_default_str();
  room->add_option("--baseline", a->baseline, "stereo baseline for the kitti layout, metres")->capture_default_str();
  size_opts(room);
  auto* street = app.add_subcommand("street", "city-grid street drive with loops, stereo (KITTI layout, 10 Hz, 1 m/frame)");
  street->add_option("--out", a->out, "output folder")->required();
  street->add_option("--length-m", a->length_m, "route length in metres")->capture_default_str();
  street->add_option("--frames", a->max_frames, "stop after this many frames (0: whole route)");
  size_opts(street);
  auto* mesh = app.add_subcommand("mesh", "render a vertex-coloured PLY mesh along a trajectory file");
  mesh->add_option("--mesh", a->mesh, "PLY mesh, with vertex colours (without them it is drawn flat grey, lit)")->required();
  mesh->add_option("--traj", a->traj, "trajectory: TUM, KITTI or 4x4-per-line (Replica traj.txt)")->required();
  mesh->add_option("--intrinsics", a->intrinsics, "fx,fy,cx,cy,width,height or a cam_params.json")->required();
  mesh->add_option("--out", a->out, "output folder")->required();
  mesh->add_option("--layout", a->layout, "tum or kitti")->capture_default_str();
  mesh->add_option("--baseline", a->baseline, "stereo baseline for the kitti layout, metres")->capture_default_str();
  mesh->add_option("--every", a->every, "use every N-th pose")->capture_default_str();
  mesh->add_option("--frames", a->max_frames, "at most this many frames (0: all)");
  mesh->add_flag("--no-depth", a->no_depth, "KITTI layout: leave out depth/ (uint16, metres * 256)");
  mesh->add_option("--rate", a->rate_hz, "frame rate for trajectories without stamps")->capture_default_str();
  auto* check = app.add_subcommand("check-office0", "render office0 at its first pose and compare with the real depth");
  check->add_option("--data", a->data, "the replica_office0 folder")->required();
  check->add_flag("--json", a->json, "print JSON");
  return [a, room, street, mesh, check]() -> int {
    for (const CLI::App* s : {room, street, mesh})
      if (s->parsed()) check_flags(*s, *a);
    if (room->parsed()) return run_room(*a);
    if (street->parsed()) return run_street(*a);
    if (mesh->parsed()) return run_mesh(*a);
    if (check->parsed()) return run_check(*a);
    return 2;
  };
});

}  // namespace
}  // namespace chungs::app
