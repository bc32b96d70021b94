// `diskchungs pareto`: one dataset mapped at several time budgets (steps per keyframe under fixed
// pacing, intake speeds under anytime pacing), each point by the same run_mapping as `diskchungs
// run`, into a folder of its own under --out; then the quality against processing FPS as a table
// (pareto.csv, pareto.json) and a plot (pareto.png), like the paper's Figure 1.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>

#include "chungs/common/log.hpp"
#include "chungs/common/text_file.hpp"
#include "chungs/eval/lpips.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/store/atomic_file.hpp"
#include "command.hpp"
#include "dataset_spec.hpp"
#include "flag_checks.hpp"
#include "map_flags.hpp"
#include "pareto_points.hpp"

namespace chungs::app {
namespace {

namespace fs = std::filesystem;

struct ParetoArgs {
  MapFlags map;
  std::string out, iterations = "10,30,100,300", speeds = "0.5,1,2";
};

struct Point {
  ParetoSetting setting;
  RunOptions options;
};

// The report a finished earlier run of this point left, or null where there is none. A report made
// with other settings is refused rather than mixed into the table: a Pareto run continued with a
// changed flag would otherwise compare points mapped differently.
nlohmann::json finished_report(const Point& p, const Dataset& dataset) {
  const fs::path file = p.options.out / "report.json";
  if (!fs::exists(file)) return nullptr;
  nlohmann::json r;
  try {
    const std::string text = read_file_text(file);
    require_json_nesting(text, file);
    r = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail(file.string(), ": not a readable report (", e.what(), "); remove ", p.options.out.string(),
         " to map this point again");
  }
  const Config& c = p.options.config;
  const size_t frames = p.options.max_frames ? std::min(p.options.max_frames, dataset.size()) : dataset.size();
  const double width = dataset.info().camera.width * c.mapper.resolution;
  auto mismatch = [&](const std::string& what, const nlohmann::json& had, const nlohmann::json& wanted) {
    fail(file.string(), ": the point was mapped with ", what, " ", had.dump(), ", not ", wanted.dump(),
         "; remove ", p.options.out.string(), " to map it again, or choose another --out");
  };
  if (!r.is_object() || !r.contains("settings") || !r.contains("time") || !r.contains("gaussians"))
    fail(file.string(), ": not a report of `diskchungs run`; remove ", p.options.out.string(),
         " to map this point again");
  const nlohmann::json& s = r["settings"];
  auto same = [&](const char* what, const nlohmann::json& had, const nlohmann::json& wanted) {
    const bool eq = had.is_number() && wanted.is_number()
                        ? std::abs(had.get<double>() - wanted.get<double>()) <= 1e-9 * std::abs(wanted.get<double>())
                        : had == wanted;
    if (!eq) mismatch(what, had, wanted);
  };
  same("dataset", r.value("dataset", nlohmann::json()), p.options.dataset);
  same("poses", r.value("poses", nlohmann::json()), p.options.poses);
  same("frames", r.value("frames", nlohmann::json()), frames);
  same("pacing", s.value("pacing", nlohmann::json()), c.mapper.pacing);
  if (p.setting.anytime)
    same("speed", s.value("speed", nlohmann::json()), c.mapper.speed);
  else
    same("iterations per keyframe", s.value("iterations_per_keyframe", nlohmann::json()),
         c.mapper.iterations_per_keyframe);
  same("final iterations", s.value("final_iterations", nlohmann::json()), c.mapper.final_iterations);
  same("budget", s.value("budget_gaussians", nlohmann::json()), c.residency.budget_gaussians);
  same("chunk size", s.value("chunk_size_m", nlohmann::json()), c.store.chunk_size);
  same("seed", s.value("seed", nlohmann::json()), c.mapper.seed);
  same("holdout_every", s.value("holdout_every", nlohmann::json()), c.mapper.holdout_every);
  same("depth weight", s.value("lambda_depth", nlohmann::json()), c.loss.lambda_depth);
  same("position learning rate", s.value("lr_position", nlohmann::json()), c.adam.lr_position);
  same("rates' reference steps", s.value("lr_reference_steps", nlohmann::json()), c.adam.reference_steps);
  same("sampler density", s.value("sampler_density", nlohmann::json()), c.sampler.density);
  same("image width", r.contains("resolution") ? r["resolution"][0] : nlohmann::json(), width);
  if (!r.contains("held_out"))
    fail(file.string(), ": the point was mapped without evaluation; remove ", p.options.out.string(),
         " to map it again");
  return r;
}

void write_results(const fs::path& dir, const ParetoArgs& a, const std::vector<nlohmann::json>& rows) {
  const std::string csv = pareto_csv(rows);
  const ConstBuffer part{csv.data(), csv.size()};
  write_file_atomically(dir / "pareto.csv", std::span<const ConstBuffer>(&part, 1), false);
  nlohmann::json j = {{"dataset", a.map.o.dataset}, {"poses", a.map.o.poses}, {"points", rows}};
  write_json(dir / "pareto.json", j);
  std::vector<ParetoPoint> points;
  std::string lpips_unavailable;
  for (const auto& r : rows) {
    points.push_back(pareto_plot_point(r));
    if (r["held_out"].is_object() && r["held_out"].contains("lpips_unavailable"))
      lpips_unavailable = r["held_out"]["lpips_unavailable"].get<std::string>();
  }
  write_pareto_plot(dir / "pareto.png", points, lpips_unavailable);
}

const Command cmd{
    "pareto", "map a dataset at several time budgets and plot quality against processing FPS",
    [](CLI::App& app) {
      auto a = std::make_shared<ParetoArgs>();
      add_map_flags(app, a->map);
      app.add_option("--out", a->out, "folder for the points' maps (fixed-N, anytime-S) and pareto.csv/json/png")
          ->required();
      app.add_option("--iterations", a->iterations,
                     "fixed pacing points: steps per keyframe, comma-separated, or none")
          ->capture_default_str();
      app.add_option("--speeds", a->speeds,
                     "anytime pacing points: intake rate factors on the dataset's frame rate, or none")
          ->capture_default_str();
      return [a, &app]() {
        const std::vector<ParetoSetting> settings = parse_pareto_settings(a->iterations, a->speeds);
        const RunOptions base = map_flags_options(app, a->map);
        require_flag(!a->out.empty(), "--out", "a folder", "an empty path");
        const fs::path dir = a->out;
        if (fs::exists(dir) && !fs::is_directory(dir)) fail("--out ", dir.string(), " is a file, not a folder");
        std::vector<Point> points;
        for (const ParetoSetting& s : settings) {
          Point p{s, base};
          MapperConfig& m = p.options.config.mapper;
          m.pacing = s.anytime ? "anytime" : "fixed";
          if (s.anytime)
            m.speed = s.speed;
          else
            m.iterations_per_keyframe = s.iterations;
          p.options.config.validate();
          p.options.out = dir / s.folder();
          p.options.evaluate = true;
          points.push_back(p);
        }
        // Everything that can be refused is, before the first point maps: an unusable device, the
        // dataset, the LPIPS weights, and earlier points made with other settings.
        resolve_device(base.config.mapper.device);
        const auto dataset = open_map_dataset(a->map);
        lpips_setting(base.config.mapper.lpips_weights, "--lpips-weights or mapper.lpips_weights");
        std::vector<nlohmann::json> earlier;
        for (const Point& p : points) {
          earlier.push_back(finished_report(p, *dataset));
          if (earlier.back().is_null() && fs::exists(p.options.out) && base.poses == "track")
            fail(p.options.out.string(), " holds an unfinished tracked run, which cannot be continued; remove it ",
                 "to map this point again");
        }

        std::vector<nlohmann::json> rows;
        for (size_t i = 0; i < points.size(); ++i) {
          const Point& p = points[i];
          nlohmann::json report = earlier[i];
          if (!report.is_null()) {
            std::printf("point %zu/%zu: %s: finished earlier, read from %s\n", i + 1, points.size(),
                        p.setting.describe().c_str(), (p.options.out / "report.json").string().c_str());
          } else {
            RunOptions o = p.options;
            // A folder without a report is a point cut short (a time limit, a crash): it continues
            // from its last checkpoint; one that holds no map yet starts afresh either way.
            o.resume = fs::exists(o.out);
            std::printf("point %zu/%zu: %s -> %s%s\n", i + 1, points.size(), p.setting.describe().c_str(),
                        o.out.string().c_str(), o.resume ? " (continuing)" : "");
            std::fflush(stdout);
            report = run_mapping(o, *dataset);
          }
          rows.push_back(pareto_row(p.setting, report));
          const nlohmann::json& r = rows.back();
          auto db = [](const nlohmann::json& q) {  // null where no frame was scored
            if (!q.is_object() || !q["psnr"].is_number()) return std::string("n/a");
            return cat(std::fixed, std::setprecision(3), q["psnr"].get<double>(), " dB");
          };
          std::printf("  %.3f FPS over %.1f s, held-out PSNR %s, keyframes PSNR %s%s\n",
                      r["processing_fps"].get<double>(), r["mapping_s"].get<double>(),
                      db(r["held_out"]).c_str(), db(r["keyframes_eval"]).c_str(),
                      r.contains("stopped")
                          ? (" (stopped early: " + r["stopped"]["reason"].get<std::string>() + ")").c_str()
                          : "");
          std::fflush(stdout);
          // After every point, so a run cut short still leaves the table of the points it finished.
          write_results(dir, *a, rows);
        }
        std::printf("\n%s\ntable %s, %s; plot %s\n", pareto_table(rows).c_str(), (dir / "pareto.csv").string().c_str(),
                    (dir / "pareto.json").string().c_str(), (dir / "pareto.png").string().c_str());
        return 0;
      };
    }};

}  // namespace
}  // namespace chungs::app
