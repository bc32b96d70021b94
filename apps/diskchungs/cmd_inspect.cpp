// `diskchungs inspect KIND:PATH`: what a dataset reader makes of a folder (or of a synth-street spec, as
// every other command takes it), without loading images beyond what opening it needs. --json prints
// the same as one JSON object.
#include <cstdio>
#include <nlohmann/json.hpp>
#include <memory>
#include <string>

#include "chungs/datasets/dataset.hpp"
#include "command.hpp"
#include "dataset_spec.hpp"

namespace chungs::app {
namespace {

struct Options {
  std::string dataset;
  bool json = false;
};

int run_inspect(const Options& opt) {
  auto ds = open_dataset_spec(opt.dataset);
  const DatasetInfo& in = ds->info();
  // A generated dataset has no folder: the spec it was made from says where it comes from.
  const std::string path = in.path.empty() ? "generated from " + opt.dataset : in.path.string();
  const Camera& c = in.camera;
  size_t gt_frames = 0;
  for (size_t i = 0; i < ds->size(); ++i) gt_frames += ds->gt_pose(i).has_value();
  double t0 = ds->timestamp(0), t1 = ds->timestamp(ds->size() - 1);
  double path_length = gt_path_length(*ds);
  // Frames missing between two stamps (an excerpt of chosen frames, dropped frames): the tracker coasts
  // over such a gap and flags the frames after it, so say where it is.
  double gap = 0;
  size_t gap_after = 0;
  for (size_t i = 1; i < ds->size(); ++i)
    if (const double d = ds->timestamp(i) - ds->timestamp(i - 1); d > gap) gap = d, gap_after = i - 1;
  const bool gaps = in.rate_hz > 0 && gap > 3.0 / in.rate_hz;

  if (opt.json) {
    nlohmann::json j;
    j["kind"] = in.kind;
    j["path"] = path;
    j["frames"] = in.frames;
    j["width"] = c.width;
    j["height"] = c.height;
    j["color"] = in.color;
    j["intrinsics"] = {{"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy}};
    j["distortion"] = c.distorted() ? nlohmann::json(c.dist) : nlohmann::json(nullptr);
    j["baseline_m"] = in.baseline;
    j["has_depth"] = in.has_depth;
    j["has_right"] = in.has_right;
    j["has_gt"] = in.has_gt;
    j["gt_frames"] = gt_frames;
    j["rate_hz"] = in.rate_hz;
    j["first_timestamp_s"] = t0;
    j["duration_s"] = t1 - t0;
    j["largest_gap_s"] = gap;
    j["largest_gap_after_frame"] = gap_after;
    j["gt_path_length_m"] = path_length;
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  const char* yes_no[] = {"no", "yes"};
  std::printf("kind:            %s\n", in.kind.c_str());
  std::printf("path:            %s\n", path.c_str());
  std::printf("frames:          %zu\n", in.frames);
  std::printf("resolution:      %dx%d %s\n", c.width, c.height, in.color ? "colour" : "gray");
  std::printf("intrinsics:      fx %.4f  fy %.4f  cx %.4f  cy %.4f\n", c.fx, c.fy, c.cx, c.cy);
  if (c.distorted())
    std::printf("distortion:      k1 %g k2 %g p1 %g p2 %g k3 %g\n", c.dist[0], c.dist[1], c.dist[2], c.dist[3], c.dist[4]);
  else
    std::printf("distortion:      none (images are undistorted/rectified by the reader)\n");
  if (in.has_right)
    std::printf("baseline:        %.4f m\n", in.baseline);
  else
    std::printf("baseline:        - (no stereo)\n");
  std::printf("depth:           %s\n", yes_no[in.has_depth]);
  std::printf("right images:    %s\n", yes_no[in.has_right]);
  std::printf("ground truth:    %s (%zu of %zu frames)\n", yes_no[in.has_gt], gt_frames, in.frames);
  std::printf("rate:            %g Hz\n", in.rate_hz);
  std::printf("duration:        %.3f s (first stamp %.6f s)\n", t1 - t0, t0);
  if (gaps)
    std::printf("gaps:            the largest %.3f s, between frames %zu and %zu (about %.0f frames at %g Hz missing)\n",
                gap, gap_after, gap_after + 1, gap * in.rate_hz - 1, in.rate_hz);
  if (in.has_gt)
    std::printf("gt path length:  %.3f m\n", path_length);
  else
    std::printf("gt path length:  - (no ground truth)\n");
  return 0;
}

const Command inspect_cmd("inspect", "what a dataset reader finds in KIND:PATH (kitti, tum, replica, euroc, 3dmatch)",
                          [](CLI::App& app) -> Action {
                            auto opt = std::make_shared<Options>();
                            app.add_option("dataset", opt->dataset, "KIND:PATH, e.g. kitti:/data/sequences/00, or synth-street:key=value,...")
                                ->required();
                            app.add_flag("--json", opt->json, "print one JSON object");
                            return [opt] { return run_inspect(*opt); };
                          });

}  // namespace
}  // namespace chungs::app
