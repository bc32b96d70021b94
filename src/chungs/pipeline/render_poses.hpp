// Rendering a finished map folder from arbitrary poses, outside the mapper: the chunks a view sees
// are streamed through Residency under the budget (as the mapper does), so a map larger than the
// budget renders with bounded memory. The folder is only read (clean chunks are never written).
#pragma once
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "chungs/config/config.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/eval/image_metrics.hpp"
#include "chungs/geometry/trajectory.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/render/render_output.hpp"
#include "chungs/store/chunk_id.hpp"

namespace chungs {

class MapRenderer {
 public:
  // Opens the map in `folder` (manifest.txt required). The budget, culling and raster settings
  // come from `config`; keyframes.txt, when present, gives the map's mapping camera.
  MapRenderer(const std::filesystem::path& folder, const Config& config);
  ~MapRenderer();
  MapRenderer(const MapRenderer&) = delete;
  MapRenderer& operator=(const MapRenderer&) = delete;

  // Colour, depth and alpha of the map seen from `pose` (camera-to-world). A view whose chunks do
  // not fit the budget together is drawn in passes, nearest chunks first (render/render_passes.hpp).
  RenderOutput<float> render(const Camera& camera, const SE3& pose);

  const std::vector<KeyframeRecord>& keyframes() const { return keyframes_; }
  const std::filesystem::path& folder() const;
  // The camera the map was built with (its first keyframe's); throws when the map has none.
  const Camera& mapping_camera() const;
  uint64_t total_gaussians() const;
  // The map's largest chunk and its Gaussians (0, 0 for an empty map): a budget below it can never draw it.
  std::pair<ChunkId, uint64_t> largest_chunk() const;
  size_t peak_resident_gaussians() const;
  size_t budget() const;
  IoStats io_stats() const;
  size_t views_rendered() const { return views_; }
  // Visible chunks left out because one alone holds more than the budget, summed over the views.
  size_t chunks_skipped() const { return skipped_; }
  size_t views_in_passes() const { return in_passes_; }  // views whose chunks did not fit together
  uint64_t largest_view_gaussians() const { return largest_view_; }  // in one view's visible chunks

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<KeyframeRecord> keyframes_;
  size_t views_ = 0, skipped_ = 0, in_passes_ = 0;
  uint64_t largest_view_ = 0;
};

// The budget a map was made with, from its report.json (0 when the file or field is missing).
size_t map_budget_from_report(const std::filesystem::path& folder);
// The poses a map was made on (run --poses: gt, track or a file), from its run_state.json; empty when
// the folder has none (a map written by other means).
std::string map_poses_source(const std::filesystem::path& folder);

struct RenderedView {
  size_t index = 0;                // pose index or dataset frame
  std::optional<ImageMetrics> metrics;  // against the dataset image, when there is one
};

struct RenderPosesSummary {
  std::vector<RenderedView> views;
  double mean_psnr = 0, mean_ssim = 0;  // over views with metrics
  size_t scored = 0;
  double seconds = 0;
  nlohmann::json to_json() const;
};

// Renders every `stride`-th pose of `traj` with `camera` into out/render_<index>.png.
RenderPosesSummary render_trajectory(MapRenderer& renderer, const Trajectory& traj, const Camera& camera,
                                     const std::filesystem::path& out, size_t stride = 1);

// Renders every `stride`-th frame of the dataset that has a pose, at `resolution` of its images,
// writes out/render_<frame>.png (the render above the image when `stack`) and scores each render
// against the image (PSNR/SSIM on colour in [0, 1]).
RenderPosesSummary render_dataset(MapRenderer& renderer, const Dataset& dataset,
                                  const std::vector<std::optional<SE3>>& poses, double resolution,
                                  const std::filesystem::path& out, size_t stride = 1, bool stack = false);

}  // namespace chungs
