// `diskchungs eval ate|images`: trajectory accuracy (ATE, RPE) and image quality (PSNR, SSIM, LPIPS).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/geometry/trajectory.hpp"
#include "chungs/image/image_io.hpp"
#include "command.hpp"
#include "flag_checks.hpp"

namespace chungs::app {
namespace {

struct EvalArgs {
  std::string gt, est, align = "se3";
  double max_dt = 0.02;
  int rpe_delta = 1;
  std::string ref, test, mask, lpips_weights;
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
  const Alignment align = parse_alignment(a.align);
  // KITTI files carry no stamps: read_trajectory gives both i / 10 s, so they pair by index.
  const Trajectory gt = read_trajectory(a.gt), est = read_trajectory(a.est);
  AteResult ate;
  RpeResult rpe;
  try {
    ate = compute_ate(gt, est, {align, a.max_dt});
    rpe = compute_rpe(gt, est, ate, a.rpe_delta);
  } catch (const Error& e) {
    fail(a.est, " against ", a.gt, ": ", e.what());
  }
  if (a.json) {
    nlohmann::json j = {{"gt", a.gt}, {"est", a.est}, {"max_dt", a.max_dt}, {"ate", to_json(ate)},
                        {"rpe", to_json(rpe)}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("ATE (%s alignment, %zu of %zu estimated poses matched within %g s, scale %s)\n",
              alignment_name(ate.align), ate.matched(), est.size(), a.max_dt, fmt(ate.alignment.s).c_str());
  std::printf("  rmse   %s m\n  mean   %s m\n  median %s m\n  max    %s m\n", fmt(ate.stats.rmse).c_str(),
              fmt(ate.stats.mean).c_str(), fmt(ate.stats.median).c_str(), fmt(ate.stats.max).c_str());
  std::printf("RPE (delta %d frames, %zu pairs)\n", rpe.delta, rpe.trans.count);
  std::printf("  translation rmse %s m, max %s m\n", fmt(rpe.trans.rmse).c_str(), fmt(rpe.trans.max).c_str());
  std::printf("  rotation    rmse %s deg, max %s deg\n", fmt(rpe.rot_deg.rmse).c_str(),
              fmt(rpe.rot_deg.max).c_str());
  return 0;
}

int run_images(const EvalArgs& a) {
  const auto pairs = match_image_pairs(a.ref, a.test);
  Image8 mask;
  if (!a.mask.empty()) mask = read_mask(a.mask);
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

const Command eval_cmd("eval", "trajectory accuracy (ATE, RPE) and image quality (PSNR, SSIM, LPIPS)",
                       [](CLI::App& app) -> Action {
  auto args = std::make_shared<EvalArgs>();
  app.require_subcommand(1);

  CLI::App* ate = app.add_subcommand("ate", "ATE and RPE of an estimated trajectory (TUM or KITTI files)");
  ate->add_option("--gt", args->gt, "ground-truth trajectory")->required();
  ate->add_option("--est", args->est, "estimated trajectory")->required();
  ate->add_option("--align", args->align, "alignment of the estimate: se3, sim3 (monocular) or none")
      ->capture_default_str();
  ate->add_option("--max-dt", args->max_dt, "largest stamp difference of a matched pair, seconds")
      ->capture_default_str();
  ate->add_option("--rpe-delta", args->rpe_delta, "RPE frame delta (in matched frames)")->capture_default_str();
  ate->add_flag("--json", args->json, "print the results as JSON");

  CLI::App* images = app.add_subcommand("images", "PSNR, SSIM and LPIPS of rendered images against references");
  images->add_option("--ref", args->ref, "reference image or folder")->required();
  images->add_option("--test", args->test, "test image or folder (files paired with --ref by name)")->required();
  images->add_option("--mask", args->mask, "mask image: pixels with all channels 0 are not scored");
  images->add_option("--lpips-weights", args->lpips_weights,
                     "LPIPS (alex, v0.1) weights converted by scripts/lpips_convert.py; without them no LPIPS");
  images->add_flag("--json", args->json, "print the results as JSON (infinite PSNR as null)");

  return [args, ate, images]() -> int {
    if (ate->parsed()) {
      // Checked here, with the flag named: the metrics' own checks named neither flag nor file.
      require_flag(std::isfinite(args->max_dt) && args->max_dt >= 0, "--max-dt", "0 or more seconds",
                   args->max_dt);
      require_flag(args->rpe_delta >= 1, "--rpe-delta", "at least 1 frame", args->rpe_delta);
      return run_ate(*args);
    }
    if (images->parsed()) {
      require_flag(!given(*images, "--lpips-weights") || !args->lpips_weights.empty(), "--lpips-weights",
                   "a weights file", "an empty path");
      return run_images(*args);
    }
    return 2;
  };
});

}  // namespace
}  // namespace chungs::app
