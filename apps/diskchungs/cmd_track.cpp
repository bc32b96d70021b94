// `diskchungs track`: runs the visual tracker over a dataset, writes the trajectory (TUM or KITTI) and, when
// the dataset has ground truth, prints the ATE after rigid alignment.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/common/output_paths.hpp"
#include "chungs/common/progress.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/datasets/mono_view.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/geometry/trajectory.hpp"
#include "chungs/pipeline/tracker_feed.hpp"
#include "chungs/tracking/visual_tracker.hpp"
#include "command.hpp"
#include "dataset_spec.hpp"
#include "eval_plot.hpp"
#include "flag_checks.hpp"

namespace chungs::app {
namespace {

namespace fs = std::filesystem;

struct TrackArgs {
  std::string dataset, out, format = "tum", input = "auto";
  long long max_frames = 0;  // signed: a typed -1 is refused, not wrapped to "all frames"
  bool no_ba = false, no_loop = false, json = false;
  int kf_min_interval = -1, kf_max_interval = -1;
  double rgbd_baseline = 0;
};

// Range checks with the flag named; the intervals' -1 means "the tracker's default" only when not typed.
void check_flags(const CLI::App& app, const TrackArgs& a) {
  if (given(app, "--input")) {
    const bool known = a.input == "auto" || a.input == "mono";
    require_flag(known, "--input", "auto or mono", a.input);
  }
  if (given(app, "--max-frames"))
    require_flag(a.max_frames >= 0, "--max-frames", "0 (all) or more", a.max_frames);
  if (given(app, "--kf-min-interval"))
    require_flag(a.kf_min_interval >= 0, "--kf-min-interval", "0 or more frames", a.kf_min_interval);
  if (given(app, "--kf-max-interval"))
    require_flag(a.kf_max_interval >= 0, "--kf-max-interval", "0 (no limit) or more frames",
                 a.kf_max_interval);
  // A minimum beyond the maximum left the maximum to win without a word.
  if (a.kf_min_interval >= 0 && a.kf_max_interval > 0)
    require_flag(a.kf_min_interval <= a.kf_max_interval, "--kf-min-interval",
                 cat("at most --kf-max-interval (", a.kf_max_interval, ")"), a.kf_min_interval);
  require_flag(!a.out.empty(), "--out", "a trajectory file", "an empty path");
  if (given(app, "--rgbd-baseline"))
    require_flag(std::isfinite(a.rgbd_baseline) && a.rgbd_baseline > 0, "--rgbd-baseline",
                 "a positive number of metres", a.rgbd_baseline);
}

int run_track(const TrackArgs& a) {
  auto ds = with_input_mode(open_dataset_spec(a.dataset), parse_input_mode(a.input));
  // Before tracking, not after it: `--out FILE/x.txt` failed only once every frame was tracked.
  prepare_output_file(a.out, "trajectory");
  // The estimate once replaced the ground truth it was scored against (--out DATASET/poses.txt), and a
  // calib.txt: a file that is already in the dataset's folder is never replaced.
  if (std::error_code ec; !ds->info().path.empty() && fs::exists(a.out, ec) && lies_within(a.out, ds->info().path))
    fail("--out ", a.out, " is a file of the dataset ", a.dataset, "; write the trajectory elsewhere or to a new name");
  // Beside a device or FIFO (--out /dev/null) the side files would land in /dev: only a regular file gets them.
  const bool side_files = !fs::exists(a.out) || fs::is_regular_file(a.out);
  // One camera measures no scale: the map's unit is set at initialisation and ATE aligns with a similarity.
  const bool mono = !ds->info().has_right && !ds->info().has_depth;
  // The virtual baseline stands in for a right camera: with one (or no depth) the flag was ignored unsaid.
  if (a.rgbd_baseline > 0 && (ds->info().has_right || !ds->info().has_depth))
    fail("--rgbd-baseline ", a.rgbd_baseline, ": ", a.dataset, " is tracked ",
         ds->info().has_right ? "as stereo, with its own baseline" : "from one camera, without depth",
         "; the flag weights RGB-D depth only");
  const TrajectoryFormat format = parse_trajectory_format(a.format);
  tracking::TrackerOptions opt;
  opt.local_ba = !a.no_ba;
  opt.loop_closure = !a.no_loop;
  if (a.rgbd_baseline > 0) opt.rgbd_virtual_baseline = a.rgbd_baseline;
  if (a.kf_min_interval >= 0) (mono ? opt.mono_min_keyframe_interval : opt.min_keyframe_interval) = a.kf_min_interval;
  if (a.kf_max_interval >= 0) (mono ? opt.mono_max_keyframe_interval : opt.max_keyframe_interval) = a.kf_max_interval;
  tracking::VisualTracker tracker(opt);
  const size_t n = a.max_frames ? std::min(size_t(a.max_frames), ds->size()) : ds->size();
  Trajectory gt;
  size_t lost = 0, keyframes = 0, loops = 0, doubtful = 0;
  // Per frame: state, inliers and why the estimate is doubtful (issue 23), written beside the trajectory.
  struct FrameQuality {
    size_t index;
    double stamp;
    std::string state;
    int inliers;
    uint32_t doubts;
  };
  std::vector<FrameQuality> quality;
  std::vector<size_t> doubtful_frames;
  const auto t0 = std::chrono::steady_clock::now();
  {
    Progress bar("tracking", static_cast<long long>(n));
    for (size_t i = 0; i < n; ++i) {
      Frame f = ds->frame(i);
      auto r = tracker.track(f);
      lost += r.state == tracking::TrackState::Lost;
      keyframes += r.keyframe;
      quality.push_back({f.index, f.timestamp, tracking::state_name(r.state), r.inliers, r.doubts});
      if (r.doubtful()) ++doubtful, doubtful_frames.push_back(f.index);
      if (f.gt_pose) gt.push_back(f.timestamp, *f.gt_pose);
      for (const auto& op : tracker.take_map_operations()) loops += op.kind == tracking::MapOperation::Kind::LoopClosure;
      bar.step();
    }
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Trajectory est = tracker.trajectory();
  // Nothing to write or score: an empty trajectory file and an ATE error would not say why.
  if (est.empty())
    fail("track ", a.dataset, ": ", tracker.why_not_started(), " (", ds->info().camera.width, "x",
         ds->info().camera.height, " images); nothing was written");
  write_trajectory(a.out, est, format, mono);
  const std::string quality_file = side_files ? a.out + ".quality.csv" : "";
  if (side_files) {
    std::ofstream q(quality_file);
    q << "frame,stamp,state,inliers,doubtful,reasons\n";
    for (const auto& r : quality)
      q << r.index << ',' << cat(r.stamp) << ',' << r.state << ',' << r.inliers << ',' << (r.doubts ? 1 : 0) << ','
        << tracking::doubt_names(r.doubts) << '\n';
    q.flush();
    if (!q) fail("cannot write ", quality_file);
  }
  const auto& tm = tracker.timings();
  nlohmann::json j = {{"dataset", a.dataset},  {"out", a.out},          {"frames", n},
                      {"lost_frames", lost},   {"keyframes", keyframes}, {"loop_closures", loops},
                      {"seconds", secs},       {"doubtful_frames", doubtful},
                      {"doubtful_frame_list", doubtful_frames}, {"quality_file", quality_file},
                      {"input", mono ? "mono" : "auto"}};
  if (mono) {
    j["scale_convention"] = "median scene depth of the first keyframe = 1";
    j["map_segments"] = tm.map_segments;
    j["reinitialisations"] = tm.reinitialisations;
  }
  j.update(chungs::tracker_time_report(tm));
  const double per_frame = j["tracking_ms_per_frame"].get<double>();
  std::optional<AteResult> ate;
  if (gt.size() >= 3) {
    ate = compute_ate(gt, est, {mono ? Alignment::Sim3 : Alignment::SE3, 0.02});
    j["ate"] = to_json(*ate);
    j["gt_path_length"] = gt.path_length();
    // Beside the trajectory: both paths from above and the error along the path (as `eval ate --plot`).
    if (side_files) {
      const std::string plot = a.out + ".ate.png";
      write_ate_plot(plot, gt, est, *ate);
      j["ate_plot"] = plot;
    }
  }
  if (a.json) {
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("%s\n", tracker.describe().c_str());
  std::printf("frames %zu, keyframes %zu, lost %zu, loop closures %zu; %.1f ms/frame tracking (%.1f s with loading)\n",
              n, keyframes, lost, loops, per_frame, secs);
  if (tm.frames)
    std::printf("per frame: %s %.1f ms, pose tracking %.1f ms, keyframes (BA, culling, loops) %.1f ms\n",
                mono ? "features" : "features + stereo", tm.features_ms / double(tm.frames), tm.tracking_ms / double(tm.frames), tm.keyframe_ms / double(tm.frames));
  std::printf("doubtful estimates: %zu of %zu frames (few inliers, estimates disagreeing, implausible motion, coasting\n"
              "  behind a moving object or an ambiguous motion; per frame in %s)\n", doubtful, n, quality_file.c_str());
  if (mono)
    std::printf("monocular: scale set at initialisation (median scene depth of the first keyframe = 1 map unit); "
                "%zu map segment(s), %zu re-initialisation(s) after a loss\n",
                tm.map_segments, tm.reinitialisations);
  std::printf("trajectory written to %s (%s)\n", a.out.c_str(), a.format.c_str());
  if (ate)
    std::printf("ATE (%s alignment, %zu poses%s): rmse %.4f m (%.2f %% of the path), max %.4f m over a %.1f m path%s\n",
                alignment_name(ate->align), ate->matched(), mono ? cat(", scale ", ate->alignment.s).c_str() : "",
                ate->stats.rmse, 100 * ate->stats.rmse / std::max(gt.path_length(), 1e-9), ate->stats.max,
                gt.path_length(), side_files ? ("; plot " + a.out + ".ate.png").c_str() : "");
  else
    std::printf("no ground truth: ATE not computed\n");
  return 0;
}

const Command track_cmd("track", "visual SLAM tracking of a stereo, RGB-D or monocular dataset; writes the trajectory",
                        [](CLI::App& app) -> Action {
  auto args = std::make_shared<TrackArgs>();
  app.add_option("--dataset", args->dataset, "dataset as kind:path (kitti, tum, replica, euroc, 3dmatch) or synth-street:key=value,...")->required();
  app.add_option("--out", args->out, "trajectory file to write")->required();
  app.add_option("--format", args->format, "trajectory format: tum or kitti")->capture_default_str();
  app.add_option("--input", args->input, "auto (all the dataset has) or mono (left camera only: no right image, no depth)")
      ->capture_default_str();
  app.add_option("--max-frames", args->max_frames, "track only the first N frames (0: all)");
  app.add_flag("--no-ba", args->no_ba, "skip local bundle adjustment");
  app.add_flag("--no-loop", args->no_loop, "skip loop closure");
  app.add_option("--kf-min-interval", args->kf_min_interval, "frames after a keyframe before the next (default from the tracker settings)");
  app.add_option("--kf-max-interval", args->kf_max_interval, "a keyframe at least every N frames (0: no limit)");
  app.add_option("--rgbd-baseline", args->rgbd_baseline, "RGB-D: virtual stereo baseline (m) that weights the depth residual");
  app.add_flag("--json", args->json, "print the summary as JSON");
  return [args, &app] {
    check_flags(app, *args);
    return run_track(*args);
  };
});

}  // namespace
}  // namespace chungs::app
