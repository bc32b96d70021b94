#include "chungs/pipeline/evaluation.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "chungs/common/log.hpp"
#include "chungs/common/progress.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/pipeline/frame_source.hpp"
#include "chungs/pipeline/run_pipeline.hpp"

namespace chungs {

nlohmann::json ViewSetScore::to_json(bool per_view) const {
  nlohmann::json j = {{"count", views.size()},
                      {"mean_psnr", mean_psnr},
                      {"mean_ssim", mean_ssim},
                      {"mean_lpips", lpips_json(mean_lpips)},
                      {"views_in_passes", views_in_passes}};
  if (!mean_lpips) j["lpips_unavailable"] = lpips_unavailable;
  if (per_view) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& v : views)
      a.push_back({{"frame", v.frame}, {"psnr", v.metrics.psnr}, {"ssim", v.metrics.ssim}, {"lpips", lpips_json(v.lpips)}});
    j["views"] = a;
  }
  return j;
}

bool score_run(Mapper& mapper, const Dataset& dataset, const std::vector<std::optional<SE3>>& poses, size_t frames,
               const MapperConfig& mc, const std::filesystem::path& out, const LpipsSetting& lpips,
               nlohmann::json& report, const std::function<bool()>& stop) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<size_t> held, kfs;
  for (size_t i = 0; i < frames; ++i)
    if (is_held_out(i, mc.holdout_every)) held.push_back(i);
  if (mc.eval_keyframe_stride > 0)
    for (size_t k = 0; k < mapper.keyframes().size(); k += size_t(mc.eval_keyframe_stride))
      kfs.push_back(mapper.keyframes()[k].frame);
  const std::filesystem::path rd = out / "renders";
  const ViewSetScore h =
      score_views(mapper, dataset, poses, held, mc.resolution, rd, "heldout", mc.max_saved_renders, &lpips, stop);
  ViewSetScore k;
  if (!h.stopped) k = score_views(mapper, dataset, poses, kfs, mc.resolution, rd, "keyframe", 4, &lpips, stop);
  report["time"]["evaluation_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (h.stopped || k.stopped) {
    // A mean over the frames scored so far would read as the map's score.
    const std::string why = cat("scoring was stopped after ", h.views.size(), " of ", held.size(),
                                " held-out frames and ", k.views.size(), " of ", kfs.size(), " keyframes");
    report["held_out"] = {{"none", why}};
    report["keyframes_eval"] = {{"none", why}};
    log::info(why);
    return false;
  }
  report["held_out"] = h.to_json(true);
  report["keyframes_eval"] = k.to_json(false);
  if (held.empty()) {
    const std::string why = mc.holdout_every > 0
                                ? cat("every ", mc.holdout_every, "th frame is held out and the run has ", frames,
                                      " frames")
                                : std::string("mapper.holdout_every is 0: no frame is held out");
    report["held_out"]["none"] = why;
    log::info("no held-out score (", why, "); keyframes PSNR ", k.mean_psnr, " dB, SSIM ", k.mean_ssim);
  } else {
    log::info("held-out PSNR ", h.mean_psnr, " dB, SSIM ", h.mean_ssim, ", ",
              h.mean_lpips ? cat("LPIPS ", *h.mean_lpips) : "LPIPS not available (" + h.lpips_unavailable + ")",
              " over ", h.views.size(), " frames; keyframes PSNR ", k.mean_psnr, " dB, SSIM ", k.mean_ssim);
  }
  return true;
}

Image8 stack_vertically(const ImageF& top, const ImageF& bottom) {
  const ImageF a = to_rgb(top), b = to_rgb(bottom);
  const int w = std::max(a.width(), b.width());
  ImageF out(w, a.height() + b.height(), 3, 0.f);
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      for (int c = 0; c < 3; ++c) out(x, y, c) = a(x, y, c);
  for (int y = 0; y < b.height(); ++y)
    for (int x = 0; x < b.width(); ++x)
      for (int c = 0; c < 3; ++c) out(x, a.height() + y, c) = b(x, y, c);
  return to_u8(out);
}

ViewSetScore score_views(Mapper& mapper, const Dataset& dataset, const std::vector<std::optional<SE3>>& poses,
                         const std::vector<size_t>& frames, double resolution,
                         const std::filesystem::path& render_dir, const std::string& prefix, int max_saved,
                         const LpipsSetting* lpips, const std::function<bool()>& stop) {
  ViewSetScore s;
  const Lpips* metric = lpips && lpips->metric ? &*lpips->metric : nullptr;
  s.lpips_unavailable = metric ? "" : lpips ? lpips->unavailable : "LPIPS not requested";
  Progress progress("scoring " + prefix, (long long)frames.size());
  int saved = 0;
  for (size_t i : frames) {
    if (stop && stop()) {
      s.stopped = true;
      break;
    }
    progress.step();
    if (i >= poses.size() || !poses[i]) continue;
    const MappingFrame m = load_mapping_frame(dataset, i, resolution, DepthMode::None, {}, false);
    const uint64_t passes_before = mapper.renders_in_passes();
    const RenderOutput<float> r = mapper.render(m.frame.camera, *poses[i]);
    s.views_in_passes += mapper.renders_in_passes() - passes_before;
    ImageF render = r.rgb;
    for (auto& v : render.vec()) v = std::clamp(v, 0.f, 1.f);  // what an 8-bit render would show
    const ImageF ref = to_rgb_float(m.frame.left);
    ViewScore v{i, compare_images(ref, render), {}};
    if (metric) v.lpips = metric->distance(ref, render);
    s.views.push_back(v);
    if (!render_dir.empty() && saved < max_saved) {
      char name[64];
      std::snprintf(name, sizeof name, "%s_%06zu.png", prefix.c_str(), i);
      write_png(render_dir / name, stack_vertically(render, ref));
      ++saved;
    }
  }
  progress.finish();
  for (const auto& v : s.views) {
    s.mean_psnr += v.metrics.psnr;
    s.mean_ssim += v.metrics.ssim;
  }
  if (!s.views.empty()) {
    s.mean_psnr /= double(s.views.size());
    s.mean_ssim /= double(s.views.size());
  }
  if (metric && s.views.empty()) s.lpips_unavailable = "no view was scored";
  if (metric && !s.views.empty()) {
    double sum = 0;
    for (const auto& v : s.views) sum += *v.lpips;
    s.mean_lpips = sum / double(s.views.size());
  }
  return s;
}

}  // namespace chungs
