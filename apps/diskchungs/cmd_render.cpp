// `diskchungs render`: a map folder rendered along a trajectory file or a dataset's poses, chunks
// streamed under the budget; with a dataset, each render is also scored against its image.
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <filesystem>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/pipeline/frame_source.hpp"
#include "chungs/pipeline/render_poses.hpp"
#include "chungs/store/chunk_id.hpp"
#include "command.hpp"
#include "dataset_spec.hpp"
#include "flag_checks.hpp"
#include "map_paths.hpp"

namespace chungs::app {
namespace {

namespace fs = std::filesystem;

struct RenderArgs {
  std::string map, poses_file, dataset, dataset_poses, out, config_file;  // dataset_poses "": the map's
  double resolution = 0;             // 0: not given (the map's or the dataset's default)
  long long stride = 1, budget = 0;  // signed, so that a typed -1 is refused instead of wrapped
  bool stack = false, json = false;
};

// Where the dataset's frames are drawn from. A map made on tracked poses lies in a frame of its own (its
// first camera's): drawn at the dataset's ground truth it showed nothing and scored 4 dB. So by default
// the poses the map was made on (its trajectory.txt) unless it was made on ground truth.
std::string dataset_poses(const RenderArgs& a) {
  std::string made_on;
  try {
    made_on = map_poses_source(a.map);
  } catch (const Error& e) {
    // Only the default poses depend on it: the map itself still draws.
    log::warn(e.what(), "; taking the map as made on ground truth");
  }
  const fs::path own = fs::path(a.map) / "trajectory.txt";
  if (a.dataset_poses.empty()) {
    if (made_on == "track" && !fs::exists(own))
      log::warn("the map was made on --poses track, in the frame of its first camera, and ", own.string(),
                " is missing: drawing the dataset's frames at its ground truth, which may show little of the map");
    if (made_on.empty() || made_on == "gt" || !fs::exists(own)) return "gt";
    log::info("the map was made on --poses ", made_on, ": drawing the dataset's frames at the poses it was made on (",
              own.string(), "); --dataset-poses gt draws them at the dataset's ground truth");
    return own.string();
  }
  if (a.dataset_poses == "gt" && made_on == "track")
    log::warn("the map was made on --poses track, in the frame of its first camera, not the dataset's ground truth: "
              "its renders at the ground-truth poses may show little of it (--dataset-poses ", own.string(),
              " draws it at its own)");
  return a.dataset_poses;
}

int run_render(const RenderArgs& a) {
  if (a.poses_file.empty() == a.dataset.empty())
    fail("render: give exactly one of --poses FILE and --dataset KIND:PATH");
  if (!a.out.empty()) refuse_inside_map(a.out, a.map, "--out");
  if (std::error_code ec; !a.out.empty() && fs::exists(a.out, ec) && !fs::is_directory(a.out, ec))
    fail("--out ", a.out, " is not a folder (the renders are written into one)");
  // The map's own budget unless told otherwise (a configuration file's residency.budget_gaussians, then
  // --budget): renders then need no more memory than mapping did.
  Config base;
  const size_t from_report = map_budget_from_report(a.map);
  if (from_report) base.residency.budget_gaussians = from_report;
  Config c = a.config_file.empty() ? base : load_config(a.config_file, base);
  const bool from_file = c.residency.budget_gaussians != base.residency.budget_gaussians;
  if (a.budget) c.residency.budget_gaussians = size_t(a.budget);
  MapRenderer renderer(a.map, c);
  // A chunk alone above the budget can never be drawn: its views would come out with a hole.
  if (const auto [id, n] = renderer.largest_chunk(); n > renderer.budget())
    fail(a.budget      ? "--budget "
         : from_file   ? cat(a.config_file, "'s residency.budget_gaussians of ")
         : from_report ? "the map's budget (report.json) of "
                       : "the budget of ",
         renderer.budget(), ": ", chunk_name(id), " of ", a.map, " holds ", n,
         " Gaussians, more than the budget, so it could not be drawn; give a budget of at least ", n);
  const std::filesystem::path out =
      a.out.empty() ? beside_map(a.map, "-renders") : std::filesystem::path(a.out);
  RenderPosesSummary s;
  if (!a.poses_file.empty()) {
    const Trajectory traj = read_trajectory(a.poses_file);
    if (traj.empty()) fail(a.poses_file, ": no poses");
    const Camera cam = renderer.mapping_camera().scaled(a.resolution > 0 ? a.resolution : 1.0);
    if (cam.width < 1 || cam.height < 1)
      fail("--resolution ", a.resolution, ": the map's ", renderer.mapping_camera().width, "x",
           renderer.mapping_camera().height, " camera would give ", cam.width, "x", cam.height, " images");
    log::info("rendering ", traj.size(), " poses of ", a.poses_file, " at ", cam.width, "x", cam.height);
    s = render_trajectory(renderer, traj, cam, out, size_t(a.stride));
  } else {
    const auto dataset = open_dataset_spec(a.dataset);
    // By default the resolution the map was made at, so scores match the mapper's evaluation.
    double f = a.resolution;
    if (f == 0) {
      f = renderer.keyframes().empty() ? 1.0
                                       : double(renderer.mapping_camera().width) / dataset->info().camera.width;
      // A dataset of smaller images than the map was made from (another size of the same scene) is
      // drawn at its own size: no image is scaled up.
      if (f > 1) {
        log::info("the map was made at ", renderer.mapping_camera().width, " px wide, wider than the dataset's ",
                  dataset->info().camera.width, " px images: rendering them at their own size");
        f = 1;
      }
    }
    {
      // Scores need SSIM's window inside the image (a degenerate camera failed at the first frame, unnamed).
      constexpr int kMinScoredSide = 11;
      const Camera scaled = dataset->info().camera.scaled(f);
      if (scaled.width < kMinScoredSide || scaled.height < kMinScoredSide)
        fail("--resolution ", f, ": the dataset's ", dataset->info().camera.width, "x",
             dataset->info().camera.height, " images would be ", scaled.width, "x", scaled.height,
             ", below the ", kMinScoredSide, "x", kMinScoredSide, " that scoring them needs");
    }
    const auto poses = frame_poses(*dataset, dataset_poses(a));
    log::info("rendering ", a.dataset, " (", dataset->size(), " frames) at ", f, " of ",
              dataset->info().camera.width, "x", dataset->info().camera.height);
    s = render_dataset(renderer, *dataset, poses, f, out, size_t(a.stride), a.stack);
  }
  const IoStats io = renderer.io_stats();
  if (a.json) {
    nlohmann::json j = s.to_json();
    j["out"] = out.string();
    j["gaussians"] = {{"total", renderer.total_gaussians()},
                      {"peak_resident", renderer.peak_resident_gaussians()},
                      {"budget", renderer.budget()}};
    j["chunk_io"] = {{"loads", io.loads}, {"mean_load_ms", io.mean_load_ms()}};
    j["views_in_passes"] = renderer.views_in_passes();
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("rendered %zu views to %s in %.1f s; %llu Gaussians, peak resident %zu of budget %zu, %llu chunk loads",
              s.views.size(), out.string().c_str(), s.seconds, (unsigned long long)renderer.total_gaussians(),
              renderer.peak_resident_gaussians(), renderer.budget(), (unsigned long long)io.loads);
  if (renderer.views_in_passes())
    std::printf(", %zu views beyond the budget drawn in passes", renderer.views_in_passes());
  std::printf("\n");
  if (s.scored) std::printf("PSNR %.3f dB  SSIM %.4f  (mean over %zu frames)\n", s.mean_psnr, s.mean_ssim, s.scored);
  return 0;
}

const Command cmd{"render", "render a map along a trajectory file or a dataset's poses (PNG; PSNR/SSIM with a dataset)",
                  [](CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  app.add_option("--map", a->map, "map folder")->required();
  app.add_option("--poses", a->poses_file, "trajectory file (TUM, KITTI or 4x4 per line): render with the map's camera");
  app.add_option("--dataset", a->dataset, "dataset as kind:path: render its frames with its camera and score them");
  app.add_option("--dataset-poses", a->dataset_poses,
                 "with --dataset: gt or a TUM/KITTI trajectory file (default: gt for a map made on ground truth, "
                 "else the poses the map was made on, MAP/trajectory.txt)");
  app.add_option("--out", a->out,
                 "folder for the PNGs, outside the map folder (default MAP-renders beside it)");
  app.add_option("--resolution", a->resolution,
                 "image scale in (0, 1]: of the map's camera with --poses (default 1), of the dataset's images with "
                 "--dataset (default the map's mapping resolution)");
  app.add_option("--stride", a->stride, "render every n-th pose")->capture_default_str();
  app.add_option("--budget", a->budget,
                 "resident Gaussians at most (default: --config's residency.budget_gaussians, else the map's from "
                 "report.json)");
  app.add_option("--config", a->config_file, "YAML configuration (culling, raster, residency)");
  app.add_flag("--stack", a->stack, "with --dataset: write the render above the image");
  app.add_flag("--json", a->json, "print a JSON summary");
  return [a, &app]() {
    // The renderer's pool addresses its Gaussians with 32-bit slots.
    if (given(app, "--budget"))
      require_flag(a->budget >= 1 && uint64_t(a->budget) < UINT32_MAX, "--budget", cat("1 to ", UINT32_MAX - 1, " Gaussians"),
                   a->budget);
    if (given(app, "--resolution"))
      require_flag(std::isfinite(a->resolution) && a->resolution > 0 && a->resolution <= 1, "--resolution",
                   "in (0, 1]", a->resolution);
    if (given(app, "--stride")) require_flag(a->stride >= 1, "--stride", "at least 1", a->stride);
    return run_render(*a);
  };
}};

}  // namespace
}  // namespace chungs::app
