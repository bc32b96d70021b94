// `diskchungs run`: map a dataset, on given poses or tracked ones, into a chunked Gaussian map folder.
#include <cmath>
#include <cstdio>

#include "chungs/common/log.hpp"
#include "chungs/mapping/run_pipeline.hpp"
#include "command.hpp"
#include "dataset_spec.hpp"
#include "flag_checks.hpp"
#include "presets.hpp"

namespace chungs::app {
namespace {

struct RunArgs {
  RunOptions o;
  std::string config_file, preset = "auto";
  long long budget = 0, max_frames = 0;
  double chunk_size = 0, resolution = 0, speed = 0, fill_depth = 0;
  int iterations = 0, final_iterations = 0;
  std::string pacing, depth, device, lpips_weights;
  bool json = false, no_eval = false, no_ba = false, no_loop = false;
};

const Command cmd{
    "run", "map a dataset (given or tracked poses) into a chunked Gaussian map", [](CLI::App& app) {
      auto a = std::make_shared<RunArgs>();
      app.add_option("--dataset", a->o.dataset, "dataset as kind:path (kitti, tum, replica, euroc, 3dmatch)")
          ->required();
      app.add_option("--poses", a->o.poses,
                     "gt (ground truth), a TUM/KITTI trajectory file, or track (the visual tracker)")
          ->capture_default_str();
      app.add_option("--out", a->o.out, "map folder (created)")->required();
      app.add_flag("--resume", a->o.resume, "continue the run in --out from its last checkpoint");
      app.add_option("--config", a->config_file, "YAML configuration (see diskchungs info --config)");
      app.add_option("--preset", a->preset, "auto | outdoor | indoor: loss and learning-rate defaults")
          ->capture_default_str();
      app.add_option("--budget", a->budget, "resident Gaussians at most");
      app.add_option("--chunk-size", a->chunk_size, "chunk edge in metres (new maps)");
      app.add_option("--resolution", a->resolution, "image scale for mapping, (0, 1]");
      app.add_option("--iterations", a->iterations, "optimisation steps per keyframe (fixed pacing)");
      app.add_option("--final-iterations", a->final_iterations, "refinement steps after the last frame");
      app.add_option("--pacing", a->pacing, "fixed | anytime");
      app.add_option("--speed", a->speed, "anytime pacing: intake rate factor on the dataset's frame rate");
      app.add_option("--depth", a->depth, "auto | sensor | stereo | none");
      app.add_option("--fill-depth", a->fill_depth,
                     "metres for sampled pixels without depth (sky); 0: skip them");
      app.add_option("--device", a->device,
                     "auto | cuda | cpu: where the optimisation runs (auto: cuda when a GPU is usable)");
      app.add_flag("--no-ba", a->no_ba, "--poses track: no local bundle adjustment");
      app.add_flag("--no-loop", a->no_loop, "--poses track: no loop closure");
      app.add_option("--max-frames", a->max_frames, "use only the first n frames");
      app.add_flag("--no-eval", a->no_eval, "skip the held-out evaluation");
      app.add_option("--lpips-weights", a->lpips_weights,
                     "LPIPS weights (scripts/lpips_convert.py) to score the evaluation with; else no LPIPS");
      app.add_flag("--json", a->json, "print the report as JSON");
      return [a, &app]() {
        Config& c = a->o.config;
        // The preset (the dataset's, or the one named) first; a configuration file then changes only
        // the keys it names. (It used to replace everything, so a file naming only the budget lost the
        // outdoor preset on KITTI without a word.)
        apply_preset(c, a->preset, a->o.dataset);
        if (!a->config_file.empty()) c = load_config(a->config_file, c);
        if (given(app, "--budget")) {
          require_flag(a->budget >= 1, "--budget", "at least 1 Gaussian", a->budget);
          c.residency.budget_gaussians = size_t(a->budget);
        }
        if (given(app, "--chunk-size")) {
          require_chunk_size_flag(a->chunk_size);
          c.store.chunk_size = a->chunk_size;
        }
        if (given(app, "--resolution")) {
          require_flag(std::isfinite(a->resolution) && a->resolution > 0 && a->resolution <= 1, "--resolution",
                       "in (0, 1]", a->resolution);
          c.mapper.resolution = a->resolution;
        }
        if (given(app, "--iterations")) {
          require_flag(a->iterations >= 0, "--iterations", "0 or more", a->iterations);
          c.mapper.iterations_per_keyframe = a->iterations;
        }
        if (given(app, "--final-iterations")) {
          require_flag(a->final_iterations >= 0, "--final-iterations", "0 or more", a->final_iterations);
          c.mapper.final_iterations = a->final_iterations;
        }
        if (given(app, "--speed")) {
          require_flag(std::isfinite(a->speed) && a->speed > 0, "--speed", "a positive factor", a->speed);
          c.mapper.speed = a->speed;
        }
        if (given(app, "--fill-depth")) {
          require_flag(std::isfinite(a->fill_depth) && a->fill_depth >= 0, "--fill-depth", "0 or more metres",
                       a->fill_depth);
          c.sampler.fill_depth = a->fill_depth;
        }
        if (given(app, "--max-frames")) {
          require_flag(a->max_frames >= 1, "--max-frames", "at least 1", a->max_frames);
          a->o.max_frames = size_t(a->max_frames);
        }
        // Given means typed, even empty: `--pacing ""` is refused by the check below, not ignored.
        if (given(app, "--pacing")) c.mapper.pacing = a->pacing;
        if (given(app, "--depth")) c.mapper.depth = a->depth;
        if (given(app, "--device")) c.mapper.device = a->device;
        if (given(app, "--lpips-weights")) {
          require_flag(!a->lpips_weights.empty(), "--lpips-weights", "a weights file", "an empty path");
          c.mapper.lpips_weights = a->lpips_weights;
        }
        c.validate();
        a->o.evaluate = !a->no_eval;
        a->o.tracker.local_ba = !a->no_ba;
        a->o.tracker.loop_closure = !a->no_loop;
        const nlohmann::json r = run_mapping(a->o, *open_dataset_spec(a->o.dataset));
        if (a->json) {
          std::printf("%s\n", r.dump(2).c_str());
          return 0;
        }
        if (r.contains("tracking") && r["tracking"].contains("ate"))
          std::printf(
              "tracking: ATE rmse %.4f m over a %.1f m path, %zu loop closures, %zu lost frames\n",
              r["tracking"]["ate"]["rmse"].get<double>(), r["tracking"]["gt_path_length_m"].get<double>(),
              r["tracking"]["loop_closures"].get<size_t>(), r["tracking"]["lost_frames"].get<size_t>());
        if (r.contains("held_out")) {
          const auto& h = r["held_out"];
          char lpips[32];
          if (h["mean_lpips"].is_number()) std::snprintf(lpips, sizeof lpips, "%.4f", h["mean_lpips"].get<double>());
          const std::string lp = h["mean_lpips"].is_number()
                                     ? cat("LPIPS ", lpips)
                                     : cat("LPIPS: not available (", h["lpips_unavailable"].get<std::string>(), ")");
          std::printf("held-out PSNR %.3f dB  SSIM %.4f  %s  (%zu frames)", h["mean_psnr"].get<double>(),
                      h["mean_ssim"].get<double>(), lp.c_str(), h["count"].get<size_t>());
          if (r.contains("keyframes_eval"))
            std::printf("; keyframes PSNR %.3f dB", r["keyframes_eval"]["mean_psnr"].get<double>());
          std::printf("; ");
        }
        std::printf("%.1f s, %.3f FPS on %s; report %s\n", r["time"]["mapping_s"].get<double>(),
                    r["time"]["processing_fps"].get<double>(), r["device"].get<std::string>().c_str(),
                    (a->o.out / "report.json").string().c_str());
        if (r.contains("pacing")) {
          // A run that starves the optimiser says so here, before anyone looks at the renders.
          const auto& p = r["pacing"];
          std::printf("pacing: %.1f steps per keyframe (lowest minute %.1f, floor %d), %llu keyframes dropped, "
                      "checkpoints %.2f %% of the time, I/O wait %.2f %%",
                      p["steps_per_keyframe_mean"].get<double>(), p["steps_per_keyframe_lowest_minute"].get<double>(),
                      p["min_steps_per_keyframe"].get<int>(), p["dropped_keyframes"].get<unsigned long long>(),
                      100 * p["checkpoint_share"].get<double>(), 100 * r["time"]["io_wait_share"].get<double>());
          if (p["path_m"].get<double>() > 0)
            std::printf("; per 100 m: %.0f Gaussians sampled, %.0f pruned", p["sampled_per_100m"].get<double>(),
                        p["pruned_per_100m"].get<double>());
          std::printf("\n");
        }
        if (r["memory"].contains("after_budget")) {
          // Flat memory is the point of the chunked map: say how level it stayed once the budget was full.
          const auto& f = r["memory"]["after_budget"];
          auto line = [&](const char* what, const nlohmann::json& m) {
            const double settled = m["settled_after_s"].get<double>();
            std::printf(
                "%s after the budget was reached: plateau %.0f MB, +%.1f %% / -%.1f %%, %.0f %% of samples "
                "within %.0f %%",
                what, m["plateau_mb"].get<double>(), 100 * m["max_above"].get<double>(),
                100 * m["max_below"].get<double>(), 100 * m["within_share"].get<double>(),
                100 * f["tolerance"].get<double>());
            if (settled >= 0) std::printf(", all from %.0f s on", settled);
            std::printf("\n");
          };
          line("host RSS", f["rss"]);
          if (f.contains("vram")) line("VRAM", f["vram"]);
        }
        if (r.contains("stopped")) {
          std::fprintf(stderr, "stopped early at frame %zu: %s (%zu Gaussians)\n",
                       r["stopped"]["frame"].get<size_t>(), r["stopped"]["reason"].get<std::string>().c_str(),
                       r["stopped"]["gaussians"].get<size_t>());
          return 3;
        }
        return 0;
      };
    }};

}  // namespace
}  // namespace chungs::app
