// Scoring a map: render views of a dataset from the map and compare them with the images.
#pragma once
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/eval/image_metrics.hpp"
#include "chungs/eval/lpips.hpp"
#include "chungs/mapping/mapper.hpp"

namespace chungs {

struct ViewScore {
  size_t frame = 0;
  ImageMetrics metrics;
  std::optional<double> lpips;
};

struct ViewSetScore {
  std::vector<ViewScore> views;
  double mean_psnr = 0, mean_ssim = 0;
  std::optional<double> mean_lpips;
  std::string lpips_unavailable;  // why mean_lpips is absent: written in its place, never a number
  size_t views_in_passes = 0;     // views beyond the budget, drawn in passes (render/render_passes.hpp)
  bool stopped = false;           // `stop` said so before every frame was scored
  nlohmann::json to_json(bool per_view) const;
};

// Renders frames `frames` of the dataset (at the mapping resolution) from the map, scores them
// against the images (colour in [0, 1], gray replicated to RGB) and, when render_dir is not empty,
// writes up to max_saved PNGs "<prefix>_<frame>.png" with the render above the image. LPIPS is
// scored where `lpips` holds a metric. Stops before the next frame once `stop` returns true.
ViewSetScore score_views(Mapper& mapper, const Dataset& dataset, const std::vector<std::optional<SE3>>& poses,
                         const std::vector<size_t>& frames, double resolution,
                         const std::filesystem::path& render_dir, const std::string& prefix, int max_saved,
                         const LpipsSetting* lpips = nullptr, const std::function<bool()>& stop = {});

// Scores a finished run of `frames` frames: its held-out frames (run_pipeline.hpp's is_held_out) and
// every mc.eval_keyframe_stride-th keyframe, renders under out/renders. Sets report's "held_out" (with
// "none" saying why when no frame is held out, instead of a mean over nothing), "keyframes_eval" and
// time.evaluation_s, and logs the scores. Once `stop` returns true it scores no further frame and
// returns false, "held_out" and "keyframes_eval" then holding only "none" with how far it got.
bool score_run(Mapper& mapper, const Dataset& dataset, const std::vector<std::optional<SE3>>& poses, size_t frames,
               const MapperConfig& mc, const std::filesystem::path& out, const LpipsSetting& lpips,
               nlohmann::json& report, const std::function<bool()>& stop = {});

// Render above reference, 8-bit RGB.
Image8 stack_vertically(const ImageF& top, const ImageF& bottom);

}  // namespace chungs
