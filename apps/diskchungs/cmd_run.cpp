// `diskchungs run`: map a dataset, on given poses or tracked ones, into a chunked Gaussian map folder.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "chungs/common/log.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/pipeline/run_report.hpp"
#include "chungs/serve/live_view.hpp"
#include "chungs/store/manifest.hpp"
#include "command.hpp"
#include "dataset_spec.hpp"
#include "flag_checks.hpp"
#include "map_flags.hpp"
#include "stop_signal.hpp"

namespace chungs::app {
namespace {

struct RunArgs {
  MapFlags map;
  double speed = 0;
  int iterations = 0;
  std::string pacing;
  bool json = false, no_eval = false;
  std::vector<std::string> view;  // --view [PORT]: the browser viewer during the run
};

const Command cmd{
    "run", "map a dataset (given or tracked poses) into a chunked Gaussian map", [](CLI::App& app) {
      auto a = std::make_shared<RunArgs>();
      add_map_flags(app, a->map);
      app.add_option("--out", a->map.o.out, "map folder (created)")->required();
      app.add_flag("--resume", a->map.o.resume, "continue the run in --out from its last checkpoint");
      app.add_option("--iterations", a->iterations, "optimisation steps per keyframe (fixed pacing)");
      app.add_option("--pacing", a->pacing, "fixed | anytime");
      app.add_option("--speed", a->speed, "anytime pacing: intake rate factor on the dataset's frame rate");
      app.add_flag("--no-eval", a->no_eval, "skip the held-out evaluation");
      app.add_flag("--json", a->json, "print the report as JSON");
      app.add_option("--view", a->view, "serve the viewer page during the run on 127.0.0.1:PORT (default 8080)")
          ->expected(0, 1);
      return [a, &app]() {
        RunOptions o = map_flags_options(app, a->map);
        Config& c = o.config;
        if (given(app, "--iterations")) {
          require_flag(a->iterations >= 0, "--iterations", "0 or more", a->iterations);
          c.mapper.iterations_per_keyframe = a->iterations;
        }
        if (given(app, "--speed")) {
          require_flag(a->speed >= kMinSpeed && a->speed <= kMaxSpeed, "--speed",
                       cat("a factor from ", kMinSpeed, " to ", kMaxSpeed), a->speed);
          c.mapper.speed = a->speed;
        }
        // Given means typed, even empty: `--pacing ""` is refused by the check below, not ignored.
        if (given(app, "--pacing")) c.mapper.pacing = a->pacing;
        c.validate();
        // The intake rate exists only under anytime pacing: a user timing a run at twice the rate would
        // otherwise get a fixed-pacing map and no sign that the flag did nothing.
        if (given(app, "--speed") && c.mapper.pacing == "fixed")
          log::warn("--speed ", a->speed, " sets the intake rate of anytime pacing and changes nothing under fixed "
                    "pacing (the default); add --pacing anytime to map at that rate");
        if (given(app, "--iterations") && c.mapper.pacing == "anytime")
          log::warn("--iterations ", a->iterations, " sets the steps a keyframe of fixed pacing and changes nothing under "
                    "anytime pacing, where the time between frames sets them (at least mapper.min_steps_per_keyframe, ",
                    c.mapper.min_steps_per_keyframe, ")");
        // A map keeps the chunk size it was made with: a typed other one would be ignored, not used.
        if (o.resume && given(app, "--chunk-size") && std::filesystem::exists(o.out / "manifest.txt")) {
          const double has = Manifest::read(o.out / "manifest.txt").chunk_size;
          if (has != c.store.chunk_size)
            fail("--chunk-size ", c.store.chunk_size, ": the map in ", o.out.string(), " has ", has,
                 " m chunks, which it keeps; resume without --chunk-size, or start a new map");
        }
        o.evaluate = !a->no_eval;
        std::unique_ptr<serve::LiveView> view;
        if (given(app, "--view")) {
          const std::string port = a->view.empty() ? "8080" : a->view[0];
          const bool digits = !port.empty() && port.size() <= 5 && port.find_first_not_of("0123456789") == std::string::npos;
          require_flag(digits && std::stol(port) <= 65535, "--view", "a port in 0..65535", port);
          view = std::make_unique<serve::LiveView>(o.out, serve::ViewServerOptions{"127.0.0.1", int(std::stol(port)), {}});
          std::printf("viewer at %s (the map appears with the run's first checkpoint)\n", view->url().c_str());
          std::fflush(stdout);
        }
        const StopSignal signal(
            "\ndiskchungs: stopping after the step under way (a frame being added is finished first) and committing the map there; "
            "a run scoring its finished map stops scoring and writes its report without the scores; Ctrl-C again "
            "quits at once, leaving the map as last committed\n");
        o.stop = &signal.stop();
        const nlohmann::json r = run_mapping(o, *open_map_dataset(a->map));
        view.reset();  // the run is over: `diskchungs view MAP` shows the finished map
        if (r.contains("interrupted")) {
          if (a->json) std::printf("%s\n", r.dump(2).c_str());  // a script reads where the run stood
          const nlohmann::json& s = r["interrupted"];
          if (s.value("scoring", false)) {
            std::fprintf(stderr,
                         "interrupted while scoring: %s holds the finished map (%zu keyframes, %llu Gaussians) and "
                         "its report without scores; the same command with --resume scores it\n",
                         o.out.string().c_str(), s["keyframes"].get<size_t>(),
                         (unsigned long long)s["gaussians"].get<uint64_t>());
            return 130;
          }
          std::fprintf(stderr,
                       "interrupted %s: %s holds the map committed there (%zu keyframes, %llu Gaussians); "
                       "the same command with --resume %s\n",
                       s["refining"].get<bool>()
                           ? "during the refinement"
                           : cat("at frame ", s["next_frame"].get<size_t>(), " of ", s["frames"].get<size_t>()).c_str(),
                       o.out.string().c_str(), s["keyframes"].get<size_t>(),
                       (unsigned long long)s["gaussians"].get<uint64_t>(),
                       s["refining"].get<bool>() ? "refines and scores it" : "maps the rest");
          return 130;  // as a shell reports a command ended by SIGINT
        }
        if (a->json) {
          std::printf("%s\n", r.dump(2).c_str());
          return 0;
        }
        if (r.contains("tracking") && r["tracking"].contains("ate")) {
          const nlohmann::json& t = r["tracking"];
          // No keyframe is made from a doubtful pose: a user comparing maps must see how many and where.
          const size_t doubtful = t.value("doubtful_frames", size_t(0));
          std::string where;
          if (doubtful && t.contains("doubtful_frame_list")) {
            const auto& list = t["doubtful_frame_list"];
            for (size_t i = 0; i < list.size() && i < 5; ++i) where += cat(i ? ", " : " (frames ", list[i].get<size_t>());
            where += list.size() > 5 ? cat(" and ", list.size() - 5, " more)") : ")";
          }
          std::printf(
              "tracking: ATE (%s alignment) rmse %.4f m over a %.1f m path, %zu loop closures, %zu lost frames%s\n",
              t["ate"]["alignment"].get<std::string>().c_str(), t["ate"]["rmse"].get<double>(),
              t["gt_path_length_m"].get<double>(), t["loop_closures"].get<size_t>(), t["lost_frames"].get<size_t>(),
              doubtful ? cat(", ", doubtful, " doubtful poses", where).c_str() : "");
        }
        if (r.contains("held_out")) {
          const auto& h = r["held_out"];
          char lpips[32];
          if (h["mean_lpips"].is_number()) std::snprintf(lpips, sizeof lpips, "%.4f", h["mean_lpips"].get<double>());
          const std::string lp = h["mean_lpips"].is_number()
                                     ? cat("LPIPS ", lpips)
                                     : cat("LPIPS: not available (", h["lpips_unavailable"].get<std::string>(), ")");
          if (h.contains("none"))
            std::printf("held-out: none (%s)", h["none"].get<std::string>().c_str());
          else
            std::printf("held-out PSNR %.3f dB  SSIM %.4f  %s  (%zu frames)", h["mean_psnr"].get<double>(),
                        h["mean_ssim"].get<double>(), lp.c_str(), h["count"].get<size_t>());
          if (r.contains("keyframes_eval"))
            std::printf("; keyframes PSNR %.3f dB", r["keyframes_eval"]["mean_psnr"].get<double>());
          std::printf("; ");
        }
        std::printf("%.1f s, %.3f FPS on %s; report %s\n", r["time"]["mapping_s"].get<double>(),
                    r["time"]["processing_fps"].get<double>(), r["device"].get<std::string>().c_str(),
                    (o.out / "report.json").string().c_str());
        if (r.contains("pacing")) {
          // A run that starves the optimiser says so here, before anyone looks at the renders.
          std::printf("%s\n", pacing_line(r).c_str());
          if (const std::string w = training_window_line(r["pacing"]); !w.empty()) std::printf("%s\n", w.c_str());
        }
        if (const uint64_t refused = r["gaussians"].value("refused_over_budget", uint64_t(0)); refused) {
          // Map content lost to a budget below one chunk's worth: the user must see it without the log.
          std::printf("budget: %llu new Gaussians were left out of the map (their chunk could not hold them under "
                      "the budget of %llu); a budget of at least %llu holds them\n",
                      (unsigned long long)refused, r["gaussians"]["budget"].get<unsigned long long>(),
                      r["gaussians"]["least_budget_for_refused"].get<unsigned long long>());
        }
        if (r["memory"].contains("after_budget")) {
          // Flat memory is the point of the chunked map: say how level it stayed once the budget was full.
          const auto& f = r["memory"]["after_budget"];
          const double reached = f["reached_seconds"].get<double>(), from = f.value("from_seconds", reached);
          // Host memory also keeps the images of the latest keyframes: until it holds all it may, RSS grows.
          char since[96];
          std::snprintf(since, sizeof since, "%s (%.0f s on)",
                        from > reached ? "once the budget was full and the keyframe images held"
                                       : "after the budget was reached",
                        from);
          auto line = [&](const char* what, const nlohmann::json& m) {
            const double settled = m["settled_after_s"].get<double>();
            std::printf(
                "%s %s: plateau %.0f MB, +%.1f %% / -%.1f %%, %.0f %% of samples "
                "within %.0f %%",
                what, since, m["plateau_mb"].get<double>(), 100 * m["max_above"].get<double>(),
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
