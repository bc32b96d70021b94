// `diskchungs eval ate|images|depth`: trajectory accuracy (ATE, RPE), image quality (PSNR, SSIM, LPIPS)
// and depth quality (AbsRel, delta < 1.25).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/common/output_paths.hpp"
#include "chungs/eval/depth_metrics.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/geometry/trajectory.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/eval/plot_canvas.hpp"
#include "command.hpp"
#include "eval_plot.hpp"
#include "flag_checks.hpp"

namespace chungs::app {

void write_ate_plot(const std::string& file, const Trajectory& gt, const Trajectory& est, const AteResult& ate) {
  if (ate.pairs.size() < 2) fail("ATE plot ", file, ": fewer than 2 matched poses");
  // Both trajectories from above: the plane of the ground truth's two largest extents (x-y for a
  // z-up world, x-z for a camera's y-down frame), the estimate after the ATE alignment.
  std::vector<Eigen::Vector3d> g, e;
  for (auto& [i, j] : ate.pairs) g.push_back(gt.poses[i].t), e.push_back(ate.alignment * est.poses[j].t);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (auto& p : g) mean += p;
  mean /= double(g.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (auto& p : g) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Eigen::Vector3d ax = es.eigenvectors().col(2), ay = es.eigenvectors().col(1);
  auto uv = [&](const Eigen::Vector3d& p) { return Eigen::Vector2d((p - mean).dot(ax), (p - mean).dot(ay)); };
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (auto* set : {&g, &e})
    for (auto& p : *set) lo = lo.cwiseMin(uv(p)), hi = hi.cwiseMax(uv(p));
  const int W = 1200, H = 620;
  PlotCanvas cv{Image8(W, H, 3, 255)};
  const PlotRgb black{0, 0, 0}, red{215, 40, 30}, blue{30, 90, 200}, grey{190, 190, 190};
  // Left: the top view, equal scale on both axes.
  const PlotBox left{50, 60, 570, 580};
  const double span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1e-6}) * 1.05;
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  const double scale = (left.x1 - left.x0) / span;
  auto to_px = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d q = uv(p) - mid;
    return Eigen::Vector2d(0.5 * (left.x0 + left.x1) + q.x() * scale, 0.5 * (left.y0 + left.y1) - q.y() * scale);
  };
  cv.line(left.x0, left.y0, left.x1, left.y0, grey, 1);
  cv.line(left.x0, left.y1, left.x1, left.y1, grey, 1);
  cv.line(left.x0, left.y0, left.x0, left.y1, grey, 1);
  cv.line(left.x1, left.y0, left.x1, left.y1, grey, 1);
  cv.clip_to(left);
  for (size_t k = 0; k + 1 < g.size(); ++k) {
    const auto a = to_px(g[k]), b = to_px(g[k + 1]);
    cv.line(a.x(), a.y(), b.x(), b.y(), black, 3);
  }
  for (size_t k = 0; k + 1 < e.size(); ++k) {
    const auto a = to_px(e[k]), b = to_px(e[k + 1]);
    cv.line(a.x(), a.y(), b.x(), b.y(), red, 2);
  }
  const auto s0 = to_px(g.front());
  for (int d = -5; d <= 5; ++d) cv.line(s0.x() - 5, s0.y() + d, s0.x() + 5, s0.y() + d, blue, 1);  // start
  cv.unclip();
  // A scale bar of a round length, about a fifth of the panel.
  // A scale bar of 1, 2 or 5 times a power of ten metres, at most a fifth of the panel.
  const double decade = std::pow(10.0, std::floor(std::log10(0.2 * span)));
  const double bar_m = 5 * decade <= 0.2 * span ? 5 * decade : 2 * decade <= 0.2 * span ? 2 * decade : decade;
  const double bar_px = bar_m * scale;
  cv.line(left.x0 + 10, left.y1 - 14, left.x0 + 10 + bar_px, left.y1 - 14, black, 2);
  cv.text(left.x0 + 14 + int(bar_px), left.y1 - 19, plot_number(bar_m) + " M", black);
  cv.text(left.x0, 12, "FROM ABOVE, ALIGNED (" + std::string(alignment_name(ate.align)) + ")", black);
  cv.text(left.x0, 32, "GROUND TRUTH", black);
  cv.text(left.x0 + PlotCanvas::width("GROUND TRUTH  "), 32, "ESTIMATE", red);
  cv.text(left.x0 + PlotCanvas::width("GROUND TRUTH  ESTIMATE  "), 32, "START", blue);
  // Right: the position error along the path.
  std::vector<double> dist(g.size(), 0.0);
  for (size_t k = 1; k < g.size(); ++k) dist[k] = dist[k - 1] + (g[k] - g[k - 1]).norm();
  const PlotBox right{680, 60, 1170, 560};
  const PlotAxis xa = plot_axis(std::max(dist.back(), 1e-6));
  const PlotAxis ya = plot_axis(std::max(*std::max_element(ate.errors.begin(), ate.errors.end()), 1e-6));
  auto rx = [&](double d) { return right.x0 + (d - xa.start) / (xa.end - xa.start) * (right.x1 - right.x0); };
  auto ry = [&](double v) { return right.y1 - (v - ya.start) / (ya.end - ya.start) * (right.y1 - right.y0); };
  for (int t = 0; t <= ya.ticks; ++t) {
    const double v = ya.start + t * ya.step;
    cv.line(right.x0, ry(v), right.x1, ry(v), grey, 1);
    const std::string l = plot_number(v);
    cv.text(right.x0 - 8 - PlotCanvas::width(l), int(ry(v)) - kPlotTextHeight / 2, l, black);
  }
  for (int t = 0; t <= xa.ticks; ++t) {
    const double d = xa.start + t * xa.step;
    cv.line(rx(d), right.y0, rx(d), right.y1, grey, 1);
    const std::string l = plot_number(d);
    cv.text(int(rx(d)) - PlotCanvas::width(l) / 2, right.y1 + 8, l, black);
  }
  cv.clip_to(right);
  for (size_t k = 0; k + 1 < g.size(); ++k)
    cv.line(rx(dist[k]), ry(ate.errors[k]), rx(dist[k + 1]), ry(ate.errors[k + 1]), blue, 2);
  cv.line(right.x0, ry(ate.stats.rmse), right.x1, ry(ate.stats.rmse), red, 1, 6);
  cv.unclip();
  char head[160];
  std::snprintf(head, sizeof head, "POSITION ERROR (M), RMSE %.3f M (DASHED), MAX %.3f M", ate.stats.rmse, ate.stats.max);
  cv.text(right.x0 - 40, 12, head, black);
  char foot[96];
  std::snprintf(foot, sizeof foot, "DISTANCE ALONG THE GROUND TRUTH (M), %.1f M, %zu POSES", dist.back(), g.size());
  cv.text(right.x0, right.y1 + 30, foot, black);
  write_png(file, cv.img);
}

namespace {

struct EvalArgs {
  std::string gt, est, align = "auto", plot;
  double max_dt = 0.02;
  int rpe_delta = 1;
  std::string ref, test, mask, lpips_weights;
  double gt_scale = 5000, est_scale = 5000;
  bool json = false;
};

std::string fmt(double v, const char* f = "%.6f") {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

int run_ate(const EvalArgs& a) {
  std::string name = a.align;
  for (char& c : name) c = char(std::tolower(static_cast<unsigned char>(c)));
  const bool auto_align = name == "auto";
  require_flag(auto_align || name == "se3" || name == "sim3" || name == "none", "--align", "auto, se3, sim3 or none",
               a.align);
  // KITTI files carry no stamps: read_trajectory gives both i / 10 s, so they pair by index.
  const Trajectory gt = read_trajectory(a.gt), est = read_trajectory(a.est);
  // One camera measures no scale: a monocular run's file says so (track --input mono), and auto then
  // aligns with a similarity; a rigid alignment would score the tracker's unit as error.
  const bool mono = trajectory_is_monocular(a.est);
  const Alignment align = auto_align ? (mono ? Alignment::Sim3 : Alignment::SE3) : parse_alignment(a.align);
  std::string why;
  if (auto_align && mono)
    why = cat(a.est, " says it comes from a monocular run (its scale is the tracker's own): sim3 alignment chosen");
  else if (mono && align == Alignment::SE3)
    why = cat("note: ", a.est, " comes from a monocular run, whose scale is the tracker's own: --align sim3 "
              "measures the path's shape");
  AteResult ate;
  RpeResult rpe;
  try {
    ate = compute_ate(gt, est, {align, a.max_dt});
    rpe = compute_rpe(gt, est, ate, a.rpe_delta);
  } catch (const Error& e) {
    fail(a.est, " against ", a.gt, ": ", e.what());
  }
  if (!a.plot.empty()) write_ate_plot(a.plot, gt, est, ate);
  if (a.json) {
    nlohmann::json j = {{"gt", a.gt},           {"est", a.est},        {"max_dt", a.max_dt},
                        {"ate", to_json(ate)},  {"rpe", to_json(rpe)}, {"estimate_monocular", mono},
                        {"alignment_chosen_by", auto_align ? "auto" : "--align"}};
    if (!a.plot.empty()) j["plot"] = a.plot;
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  if (!why.empty()) std::printf("%s\n", why.c_str());
  std::printf("ATE (%s alignment, %zu of %zu estimated poses matched within %g s, scale %s)\n",
              alignment_name(ate.align), ate.matched(), est.size(), a.max_dt, fmt(ate.alignment.s).c_str());
  std::printf("  rmse   %s m\n  mean   %s m\n  median %s m\n  max    %s m\n", fmt(ate.stats.rmse).c_str(),
              fmt(ate.stats.mean).c_str(), fmt(ate.stats.median).c_str(), fmt(ate.stats.max).c_str());
  std::printf("RPE (delta %d frames, %zu pairs)\n", rpe.delta, rpe.trans.count);
  std::printf("  translation rmse %s m, max %s m\n", fmt(rpe.trans.rmse).c_str(), fmt(rpe.trans.max).c_str());
  std::printf("  rotation    rmse %s deg, max %s deg\n", fmt(rpe.rot_deg.rmse).c_str(),
              fmt(rpe.rot_deg.max).c_str());
  if (!a.plot.empty()) std::printf("plot written to %s\n", a.plot.c_str());
  return 0;
}

int run_images(const EvalArgs& a) {
  const auto pairs = match_image_pairs(a.ref, a.test, ImageRole::Colour);
  Image8 mask;
  if (!a.mask.empty()) {
    mask = read_mask(a.mask);
    // An empty mask scores nothing: PSNR and SSIM of no pixel were printed as nan with exit 0.
    if (std::all_of(mask.data(), mask.data() + mask.size(), [](uint8_t v) { return v == 0; }))
      fail(a.mask, ": the mask is 0 everywhere, so no pixel would be scored");
  }
  const LpipsSetting lpips = lpips_setting(a.lpips_weights, "--lpips-weights");
  const ImageSetResult r = evaluate_image_pairs(pairs, a.mask.empty() ? nullptr : &mask, {}, &lpips);
  if (a.json) {
    nlohmann::json j = to_json(r);
    j["mask"] = a.mask.empty() ? nlohmann::json(nullptr) : nlohmann::json(a.mask);
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  for (const auto& im : r.images)
    std::printf("%-32s PSNR %8s dB  SSIM %s%s\n", im.pair.name.c_str(), fmt(im.metrics.psnr, "%.3f").c_str(),
                fmt(im.metrics.ssim, "%.4f").c_str(), im.lpips ? ("  LPIPS " + fmt(*im.lpips, "%.4f")).c_str() : "");
  std::printf("mean over %zu image(s): PSNR %s dB  SSIM %s%s%s\n", r.images.size(), fmt(r.mean_psnr, "%.3f").c_str(),
              fmt(r.mean_ssim, "%.4f").c_str(), r.mean_lpips ? ("  LPIPS " + fmt(*r.mean_lpips, "%.4f")).c_str() : "",
              r.infinite_psnr ? cat(" (", r.infinite_psnr, " identical pair(s) with infinite PSNR)").c_str() : "");
  if (!r.mean_lpips) std::printf("LPIPS: not available (%s)\n", r.lpips_unavailable.c_str());
  return 0;
}

nlohmann::json depth_json(const DepthMetrics& m) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"abs_rel", num(m.abs_rel)}, {"delta1", num(m.delta1)}, {"rmse_m", num(m.rmse)}, {"pixels", m.pixels},
          {"gt_valid", m.gt_valid}};
}

int run_depth(const EvalArgs& a) {
  const DepthSetResult r = evaluate_depth_pairs(match_image_pairs(a.gt, a.est, ImageRole::Depth), a.gt_scale, a.est_scale);
  // Metrics over no pixel were printed as nan with exit 0.
  if (r.pooled.pixels == 0)
    fail("no pixel has a valid depth in both ", a.gt, " and ", a.est, " (", r.pooled.gt_valid,
         " valid ground-truth pixels at --gt-scale ", a.gt_scale, "): nothing to score");
  if (a.json) {
    nlohmann::json j = {{"gt", a.gt}, {"est", a.est}, {"gt_scale", a.gt_scale}, {"est_scale", a.est_scale},
                        {"pooled", depth_json(r.pooled)}};
    for (const auto& im : r.images) j["images"].push_back({{"name", im.pair.name}, {"metrics", depth_json(im.metrics)}});
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  for (const auto& im : r.images)
    std::printf("%-32s AbsRel %s  d<1.25 %s  RMSE %s m  (%zu of %zu ground-truth pixels)\n", im.pair.name.c_str(),
                fmt(im.metrics.abs_rel, "%.4f").c_str(), fmt(im.metrics.delta1, "%.4f").c_str(),
                fmt(im.metrics.rmse, "%.3f").c_str(), im.metrics.pixels, im.metrics.gt_valid);
  std::printf("all %zu image(s), over pixels valid in both: AbsRel %s  d<1.25 %s  RMSE %s m  (%zu of %zu "
              "ground-truth pixels)\n",
              r.images.size(), fmt(r.pooled.abs_rel, "%.4f").c_str(), fmt(r.pooled.delta1, "%.4f").c_str(),
              fmt(r.pooled.rmse, "%.3f").c_str(), r.pooled.pixels, r.pooled.gt_valid);
  return 0;
}

const Command eval_cmd("eval", "trajectory accuracy (ATE, RPE), image quality (PSNR, SSIM, LPIPS), depth quality",
                       [](CLI::App& app) -> Action {
  auto args = std::make_shared<EvalArgs>();
  app.require_subcommand(1);

  CLI::App* ate = app.add_subcommand("ate", "ATE and RPE of an estimated trajectory (TUM or KITTI files)");
  ate->add_option("--gt", args->gt, "ground-truth trajectory")->required();
  ate->add_option("--est", args->est, "estimated trajectory")->required();
  ate->add_option("--align", args->align,
                  "alignment of the estimate: auto (sim3 when the estimate says it comes from a monocular run, "
                  "else se3), se3, sim3 or none")
      ->capture_default_str();
  ate->add_option("--max-dt", args->max_dt, "largest stamp difference of a matched pair, seconds")
      ->capture_default_str();
  ate->add_option("--rpe-delta", args->rpe_delta, "RPE frame delta (in matched frames)")->capture_default_str();
  ate->add_option("--plot", args->plot, "write a PNG: both trajectories from above after alignment, and the error along the path");
  ate->add_flag("--json", args->json, "print the results as JSON");

  CLI::App* images = app.add_subcommand("images", "PSNR, SSIM and LPIPS of rendered images against references");
  images->add_option("--ref", args->ref, "reference image or folder")->required();
  images->add_option("--test", args->test, "test image or folder (files paired with --ref by name)")->required();
  images->add_option("--mask", args->mask, "mask image: pixels with all channels 0 are not scored");
  images->add_option("--lpips-weights", args->lpips_weights,
                     "LPIPS (alex, v0.1) weights converted by scripts/lpips_convert.py; without them no LPIPS");
  images->add_flag("--json", args->json, "print the results as JSON (infinite PSNR as null)");

  CLI::App* depth = app.add_subcommand("depth", "AbsRel and delta < 1.25 of depth maps against ground truth (16-bit PNGs)");
  depth->add_option("--gt", args->gt, "ground-truth depth PNG or folder")->required();
  depth->add_option("--est", args->est, "estimated depth PNG or folder (files paired with --gt by name)")->required();
  depth->add_option("--gt-scale", args->gt_scale, "ground-truth units per metre (TUM 5000, millimetres 1000)")
      ->capture_default_str();
  depth->add_option("--est-scale", args->est_scale, "estimate units per metre")->capture_default_str();
  depth->add_flag("--json", args->json, "print the results as JSON (no valid pixel: null)");

  return [args, ate, images, depth]() -> int {
    if (ate->parsed()) {
      // Checked here, with the flag named: the metrics' own checks named neither flag nor file.
      require_flag(std::isfinite(args->max_dt) && args->max_dt >= 0, "--max-dt", "0 or more seconds",
                   args->max_dt);
      require_flag(args->rpe_delta >= 1, "--rpe-delta", "at least 1 frame", args->rpe_delta);
      if (given(*ate, "--plot")) {
        require_flag(!args->plot.empty(), "--plot", "a PNG file", "an empty path");
        refuse_output_over_input(args->plot, "--plot", args->gt, "--gt");
        refuse_output_over_input(args->plot, "--plot", args->est, "--est");
        refuse_replacing_other_than_png(args->plot, "--plot");
      }
      return run_ate(*args);
    }
    if (images->parsed()) {
      require_flag(!given(*images, "--lpips-weights") || !args->lpips_weights.empty(), "--lpips-weights",
                   "a weights file", "an empty path");
      require_flag(!given(*images, "--mask") || !args->mask.empty(), "--mask", "a mask image", "an empty path");
      return run_images(*args);
    }
    if (depth->parsed()) {
      require_flag(std::isfinite(args->gt_scale) && args->gt_scale > 0, "--gt-scale", "a positive number",
                   args->gt_scale);
      require_flag(std::isfinite(args->est_scale) && args->est_scale > 0, "--est-scale", "a positive number",
                   args->est_scale);
      return run_depth(*args);
    }
    return 2;
  };
});

}  // namespace
}  // namespace chungs::app
