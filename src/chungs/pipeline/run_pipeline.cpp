#include "chungs/pipeline/run_pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <unordered_map>

#include "chungs/common/heap.hpp"
#include "chungs/common/log.hpp"
#include "chungs/common/progress.hpp"
#include "chungs/common/stopwatch.hpp"
#include "chungs/depth/learned_prior.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/pipeline/checkpoint_cadence.hpp"
#include "chungs/pipeline/evaluation.hpp"
#include "chungs/pipeline/frame_feed.hpp"
#include "chungs/pipeline/frame_lookahead.hpp"
#include "chungs/pipeline/frame_source.hpp"
#include "chungs/pipeline/multiview_keyframes.hpp"
#include "chungs/pipeline/multiview_mapping.hpp"
#include "chungs/pipeline/pose_updates.hpp"
#include "chungs/pipeline/resume_point.hpp"
#include "chungs/pipeline/run_report.hpp"
#include "chungs/pipeline/timeline.hpp"
#include "chungs/pipeline/tracker_feed.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/disk_usage.hpp"

namespace chungs {

namespace fs = std::filesystem;

bool is_held_out(size_t frame, int holdout_every) {
  return holdout_every > 0 && frame % size_t(holdout_every) == size_t(holdout_every - 1);
}

namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

TimelineSample sample_now(const Mapper& m, double seconds, uint64_t frame, double disk_mb) {
  TimelineSample t;
  t.seconds = seconds;
  t.frame = frame;
  t.keyframes = m.keyframes().size();
  t.iterations = m.iterations();
  t.resident = m.resident_gaussians();
  t.total = m.total_gaussians();
  t.chunks = m.chunk_count();
  t.rss_mb = double(current_rss_bytes()) / (1024.0 * 1024.0);
  const IoStats io = m.io_stats();
  t.loads = io.loads;
  t.saves = io.saves;
  t.io_ms = io.load_ms + io.save_ms;
  t.read_mb = double(io.bytes_read) / 1048576.0;
  t.written_mb = double(io.bytes_written) / 1048576.0;
  t.wait_ms = m.optimiser_io_wait_ms();
  t.disk_mb = disk_mb;
  const auto dm = m.device_memory();
  t.vram_mb = dm ? dm->used_mb : 0.0;
  return t;
}

void write_text(const fs::path& file, const std::string& text) {
  const ConstBuffer part{text.data(), text.size()};
  write_file_atomically(file, std::span<const ConstBuffer>(&part, 1), false);
}

}  // namespace

nlohmann::json run_mapping(const RunOptions& o) {
  resolve_device(o.config.mapper.device);  // an unusable device fails before the dataset is read
  const auto dataset = open_dataset(o.dataset);
  return run_mapping(o, *dataset);
}

nlohmann::json run_mapping(const RunOptions& o, const Dataset& data) {
  const Config& cfg = o.config;
  cfg.mapper.validate();
  const MapperConfig& mc = cfg.mapper;
  const Dataset* dataset = &data;
  const DatasetInfo& info = dataset->info();
  DepthMode mode = resolve_depth_mode(parse_depth_mode(mc.depth), info.has_depth, info.has_right);
  // The mapper places Gaussians at depth: frames that give none (one camera, or their depth not used)
  // get it from their neighbouring keyframes.
  if (mode == DepthMode::None) mode = DepthMode::Multiview;
  const int width = std::max(1, int(std::lround(info.camera.width * mc.resolution)));
  const int height = std::max(1, int(std::lround(info.camera.height * mc.resolution)));
  {
    // The loss's SSIM window and the tracker's feature pyramid need some image: refused before the
    // folder is touched (a 2x1 mapping image used to fail only at the evaluation, after mapping).
    constexpr int kMinSide = 16;
    if (width < kMinSide || height < kMinSide)
      fail("dataset ", o.dataset, ": its ", info.camera.width, "x", info.camera.height,
           " images at resolution ", mc.resolution, " are ", width, "x", height, ", below the ", kMinSide,
           "x", kMinSide, " that mapping needs");
  }
  const bool tracked = o.poses == "track";
  // A tracker with depth or a second camera measures metres; one camera alone has its own unit.
  const bool own_unit = tracked && !info.has_depth && !info.has_right;
  if (tracked && o.resume)
    fail(o.out.string(),
         ": --resume continues runs on given poses only; for a tracked run write the "
         "trajectory with `diskchungs track` and map it with --poses FILE");
  const size_t n = o.max_frames ? std::min(o.max_frames, dataset->size()) : dataset->size();
  // Given poses are read before the map folder is touched, so a bad file changes nothing.
  std::vector<std::optional<SE3>> given;
  if (!tracked) given = frame_poses(*dataset, o.poses);
  // The LPIPS weights too: a bad file is refused now, not after the whole run.
  const LpipsSetting lpips = o.evaluate
                                 ? lpips_setting(mc.lpips_weights, "--lpips-weights or mapper.lpips_weights")
                                 : LpipsSetting{};
  if (lpips.metric && (width < kLpipsMinSide || height < kLpipsMinSide))
    fail("dataset ", o.dataset, ": ", width, "x", height, " mapping images are below the ", kLpipsMinSide,
         "x", kLpipsMinSide, " LPIPS needs (raise --resolution or drop --lpips-weights)");
  // The learned depth model as well (the CLI hands it over loaded); it serves the multiview depth only.
  std::shared_ptr<const LearnedDepth> learned = o.mono_depth_model;
  if (!learned && !mc.mono_depth_model.empty()) {
    try {
      learned = LearnedDepth::load(mc.mono_depth_model);
    } catch (const Error& e) {
      fail("mapper.mono_depth_model: ", e.what());
    }
  }
  if (learned && mode != DepthMode::Multiview)
    log::warn("--mono-depth-model: this run's depth is ", depth_mode_name(mode),
              ", so the model is not used (it gives the plane sweep of monocular input its prior)");

  // Depth from the plane sweep is a guess: its Gaussians get a higher position rate (adam.hpp).
  Config mapper_cfg = cfg;
  if (mode == DepthMode::Multiview) mapper_cfg.adam.lr_position *= cfg.adam.multiview_position_factor;
  Mapper mapper(o.out, mapper_cfg, o.resume);
  const nlohmann::json& prev = mapper.resumed_state();
  ResumePoint resumed = resume_point(o, prev, dataset->size(), n, mc.resolution);
  const size_t start = resumed.start;
  const double carried_seconds = resumed.seconds;
  std::vector<TimelineSample>& timeline = resumed.timeline;
  if (o.resume && !prev.is_null())
    log::info("resuming ", o.out.string(), " at frame ", start, " with ", mapper.keyframes().size(),
              " keyframes and ", mapper.total_gaussians(), " Gaussians");
  // The memory for chunks in flight at their limits, made resident now: host RSS stays level once
  // the budget is reached instead of rising each time a queue reaches a new high
  // (residency/host_block_pool.hpp). Only where the map can outgrow the budget (a keyframe adds at
  // most one Gaussian per pixel): a small dataset never pays for a pool sized to the budget
  // (244 MB at the default one). The heap keeps what is freed (common/heap.hpp).
  const uint64_t can_hold =
      mapper.total_gaussians() + uint64_t(n - std::min(start, n)) * uint64_t(width) * uint64_t(height);
  const bool can_fill = can_hold > cfg.residency.budget_gaussians;
  keep_heap_for_reuse(0);
  if (can_fill) mapper.in_flight_blocks().make_resident();
  log::info("mapping ", o.dataset, " (", n, " frames, ", info.camera.width, "x", info.camera.height, " x ",
            mc.resolution, ", depth ", depth_mode_name(mode), ", poses ", o.poses, ", budget ",
            cfg.residency.budget_gaussians, " Gaussians, chunks of ", cfg.store.chunk_size, " m, device ",
            mapper.device(), ")");

  const auto t0 = Clock::now();
  auto seconds = [&] { return carried_seconds + since(t0); };
  auto state = [&](size_t next_frame, bool finished) {
    return nlohmann::json{{"dataset", o.dataset},       {"poses", o.poses},          {"resolution", mc.resolution},
                          {"holdout_every", mc.holdout_every}, {"next_frame", next_frame}, {"frames", n},
                          {"finished", finished},       {"seconds", seconds()}};
  };
  // The timeline grows with the run, so it goes to run_state.json as text (Mapper::checkpoint).
  auto timeline_member = [&] {
    TextPieces out;
    out += ",\"timeline\":";
    append_json(out, timeline);
    return out;
  };
  // Frame i arrives (anytime pacing) at its dataset time divided by the speed factor.
  const double stamp0 = n ? dataset->timestamp(0) : 0;
  // The folder walk grows with the map (one file per chunk and keyframe), so it runs at most every
  // couple of seconds rather than at every keyframe.
  double disk_mb = 0, disk_measured_at = -1e9;
  const TimelineSample base = timeline.empty() ? TimelineSample() : timeline.back();
  uint64_t dropped = 0;
  double path_m = 0;
  auto record = [&](uint64_t frame) {
    if (seconds() - disk_measured_at >= 2.0) {
      disk_mb = double(disk_usage(o.out).bytes) / 1048576.0;
      disk_measured_at = seconds();
    }
    TimelineSample t = sample_now(mapper, seconds(), frame, disk_mb);
    // Counters of this process continue those of the run it resumed.
    t.sampled = base.sampled + mapper.sampled_total();
    t.pruned = base.pruned + mapper.pruned_total();
    t.dropped = base.dropped + dropped;
    t.checkpoint_ms = base.checkpoint_ms + mapper.io_stats().checkpoint_ms;
    t.path_m = base.path_m + path_m;
    timeline.push_back(t);
  };
  auto arrival = [&](size_t i) { return (dataset->timestamp(i) - stamp0) / mc.speed; };
  // A resumed real-time run starts its intake again at frame `start` as this process starts, at the speed
  // given now: the clock it carries holds the time of the run it continues, whose speed may have been
  // another (--speed 4 after 0.02 made every frame late, 25 of 41 dropped) or which may have fallen behind.
  const double pace_shift = start > 0 && start < n ? arrival(start) - carried_seconds : 0;

  // One camera measures no scale, so its tracker sets the map's unit at its first keyframe. Setting that
  // keyframe's median depth to a typical scene's metres keeps the metric settings (chunk size, far plane,
  // fill depth, position learning rate, keyframe spacing) near their meaning: with a unit of "median depth
  // 1" (~15 m on KITTI) a 10 m chunk spanned 150 m and held-out PSNR fell 0.9 dB (bench/README.md).
  tracking::TrackerOptions tracker_options = o.tracker;
  if (own_unit) tracker_options.mono_init.target_median_depth = cfg.multiview.choice.scene_depth;
  std::unique_ptr<FrameFeed> feed =
      tracked
          ? make_tracker_feed(*dataset, n, mc, tracker_options)
          : make_given_pose_feed(
                given, start, n, mc,
                mapper.keyframes().empty() ? std::nullopt : std::optional(mapper.keyframes().back().pose));
  PoseUpdateApplier updates(mapper, mc);
  std::optional<size_t> stopped_at;  // in-core comparison: the frame at which the map outgrew memory
  Progress progress("mapping", (long long)(n - std::min(start, n)));
  size_t keyframes_since_checkpoint = 0;
  double last_checkpoint = seconds();
  // From the tracker's feed only the frames it has tracked are pulled ahead (their dense stereo for
  // the map then runs side by side, where one keyframe at a time had held tracked runs below 10 Hz).
  // When each keyframe's load ran (seconds of the run), for the debug log's account of its lag.
  const bool log_lag = mc.pacing == "anytime" && log::enabled(log::Level::Debug);
  std::mutex load_times_mutex;
  std::unordered_map<size_t, std::pair<double, double>> load_times;
  StereoDepthConfig stereo = cfg.stereo;
  stereo.cuda = mapper.device() == "cuda";  // a few ms a pair there, against 50-250 ms on the host
  // One camera: each keyframe is swept against earlier ones in its load (multiview_keyframes.hpp).
  // Its prior is the tracker's map points densified, or a learned model's prediction aligned to them
  // (--mono-depth-model), with the densified points where the model's fit is refused.
  std::unique_ptr<MultiviewKeyframes> multiview;
  std::shared_ptr<const LearnedPrior> learned_prior;
  if (mode == DepthMode::Multiview) {
    std::shared_ptr<const DepthPriorSource> prior =
        std::make_shared<MapPointPrior>(cfg.multiview.min_prior_points, cfg.multiview.densify);
    if (learned)
      prior = learned_prior = std::make_shared<LearnedPrior>(learned, InverseDepthFitOptions{}, prior);
    MultiviewDepthConfig mv = cfg.multiview;
    // Outdoors the pixels without depth are mostly sky, which the sampler's fill depth puts far away; a
    // membrane between the buildings' depths would bring the sky down onto them.
    if (cfg.sampler.fill_depth > 0) mv.fill_holes = false;
    multiview = std::make_unique<MultiviewKeyframes>(*dataset, mc.resolution, mv, mapper.device() == "cuda",
                                                     !own_unit, prior);
  }
  // Measured depth polished at the sampled pixels by the sweep against earlier keyframes (issue 25).
  if (cfg.multiview.refine && (mode == DepthMode::Sensor || mode == DepthMode::Stereo)) {
    // Its cost is taken from the optimiser's thread; under a real-time intake that time is the steps
    // of the map, and what the trade gives there has not been measured: only fixed pacing refines.
    if (mc.pacing == "anytime")
      log::info(
          "multiview.refine: off under anytime pacing (it would take its time from the optimiser's steps)");
    else if (info.camera.distorted())
      log::warn("multiview.refine: the camera is distorted (", info.camera.describe(),
                "), which the plane sweep cannot use; the depth stays as measured");
    else
      mapper.set_depth_refinement(mode == DepthMode::Sensor ? cfg.multiview.refine_rgbd_range
                                                            : cfg.multiview.refine_stereo_range);
  }
  FrameLookahead ahead(
      *feed, size_t(mc.frame_lookahead),
      [&](size_t i) {
        const double begin = seconds();
        MappingFrame m;
        try {
          m = load_mapping_frame(*dataset, i, mc.resolution, mode, stereo);
        } catch (...) {
          if (multiview) multiview->failed(i, std::current_exception());  // later sweeps skip it
          throw;
        }
        if (multiview) {
          MultiviewKeyframes::Result r = multiview->depth(i, m.frame.left);
          m.depth = std::move(r.depth);
          m.late_depth = std::move(r.late);
          m.refresh_depth = std::move(r.refresh);
          if (m.depth) m.median_depth = median_valid_depth(*m.depth);
        }
        if (log_lag) {
          std::lock_guard lock(load_times_mutex);
          load_times[i] = {begin, seconds()};
        }
        return m;
      },
      mc.pacing == "anytime" ? FrameLookahead::SecondsUntil([&](size_t i) { return arrival(i) - pace_shift - seconds(); })
                             : FrameLookahead::SecondsUntil(),
      [&](const FeedItem& item) {
        if (multiview) multiview->seen(item);
      });
  const bool anytime = mc.pacing == "anytime";
  std::optional<SE3> last_pose;
  auto checkpoint_now = [&] {
    return checkpoint_due(mc, seconds() - last_checkpoint, keyframes_since_checkpoint, since(t0), mapper.io_stats());
  };
  // The optimiser thread's time outside the steps and keyframes (report.json time.optimiser_ms).
  double frames_wait_ms = 0, record_ms = 0, checkpoint_call_ms = 0, updates_ms = 0;
  auto timed = [](double& acc, auto&& f) {
    const auto a = Clock::now();
    f();
    acc += since(a) * 1000.0;
  };
  const auto stop_asked = [&] { return o.stop && o.stop->load(); };
  size_t next_frame = start;  // the frame after the last one fully handled
  bool interrupted = false;
  while (true) {
    if (stop_asked()) {
      interrupted = true;
      break;
    }
    // Real time: while a live source (the tracker) has no frame for the map yet, the map trains.
    if (anytime && !mapper.keyframes().empty())
      while (!ahead.next_ready() && !stop_asked()) mapper.step();
    std::optional<FrameLookahead::Entry> entry;
    timed(frames_wait_ms, [&] { entry = ahead.next(); });
    if (!entry) break;
    progress.step();
    const FeedItem* item = &entry->item;
    const size_t i = item->frame;
    next_frame = i + 1;  // handled in full by the next check of stop_asked()
    if (item->pose) {
      if (last_pose) path_m += (item->pose->t - last_pose->t).norm();
      last_pose = item->pose;
    }
    bool added = false;
    if (entry->has_frame()) {
      bool drop = false;
      if (anytime && !mapper.keyframes().empty()) {
        // Real time: the latest keyframe gets its floor of steps whatever the intake does (a stop cuts
        // them short: with a floor of 10^9 steps, Ctrl-C and SIGTERM waited for all of them) ...
        while (mapper.steps_since_keyframe() < uint64_t(mc.min_steps_per_keyframe) && !stop_asked()) mapper.step();
        // ... and a keyframe that a later loaded one supersedes is dropped, not queued behind.
        drop = ahead.later_keyframe_ready();
        // Otherwise the map trains until the frame has arrived and its depth is computed.
        if (!drop) {
          while (!FrameLookahead::ready(*entry) && !stop_asked()) mapper.step();
          // A slow intake (--speed 0.01) leaves seconds before the frame arrives: a stop leaves it to --resume.
          if (!FrameLookahead::ready(*entry)) {
            next_frame = i;
            interrupted = true;
            break;
          }
        }
      }
      if (drop) {
        ++dropped;
        if (log_lag) {
          std::lock_guard lock(load_times_mutex);
          load_times.erase(i);
        }
        log::debug("frame ", i, ": dropped (a later keyframe has already arrived and been loaded)");
      } else {
        MappingFrame m;
        timed(frames_wait_ms, [&] { m = entry->frame.get(); });
        give_earlier_keyframes_depth(mapper, m, i);
        feed->set_scene_depth(m.median_depth);
        if (multiview) multiview->set_scene_depth(m.median_depth);
        const SampleStats ss =
            mapper.add_keyframe(i, dataset->timestamp(i), m.frame.left, m.depth, m.frame.camera, *item->pose,
                                item->seeds.empty() ? nullptr : &item->seeds);
        updates.added(item->keyframe_id, mapper.keyframes().back().id);
        added = true;
        log::debug("frame ", i, ": ", ss.kept, " new Gaussians (", ss.candidates, " drawn, ", ss.no_depth,
                   " without depth, ", ss.excluded, " in chunks left out of the render, ", ss.capped,
                   " over the cap) in ", ss.chunks, " chunks");
        if (log_lag) {
          std::pair<double, double> load{0, 0};
          {
            std::lock_guard lock(load_times_mutex);
            if (auto it = load_times.find(i); it != load_times.end()) load = it->second, load_times.erase(it);
          }
          log::debug("frame ", i, ": arrived at ", arrival(i) - pace_shift, " s, loaded ", load.first, "-", load.second,
                     " s, added at ", seconds(), " s");
        }
        if (mc.pacing == "fixed")
          for (int k = 0; k < mc.iterations_per_keyframe && !stop_asked(); ++k) mapper.step();
      }
    }
    PoseUpdateApplier::Applied applied;
    timed(updates_ms, [&] { applied = updates.apply(item->updates); });
    if (!added && !applied.keyframes_moved) continue;
    timed(record_ms, [&] { record(i); });
    if (added) ++keyframes_since_checkpoint;
    if (checkpoint_now() || applied.loop) {
      timed(checkpoint_call_ms,
            [&] { mapper.checkpoint(state(i + 1, false), /*behind=*/true, timeline_member()); });
      keyframes_since_checkpoint = 0;
      last_checkpoint = seconds();
    }
    if (mc.in_core_only && mapper.total_gaussians() > cfg.residency.budget_gaussians) {
      stopped_at = i;
      log::warn("frame ", i, ": the map (", mapper.total_gaussians(), " Gaussians) outgrew the budget of ",
                cfg.residency.budget_gaussians,
                " and mapper.in_core_only keeps every chunk in memory: stopping");
      break;
    }
  }
  progress.finish();
  // Stopped by the user (Ctrl-C): the map as it stands is committed where --resume picks it up; nothing
  // is refined, scored or reported (the tracker's feed is left unfinished: its poses are not all known).
  const auto where_stopped = [&](size_t next, bool refining) {
    return nlohmann::json{{"next_frame", next},
                          {"frames", n},
                          {"keyframes", mapper.keyframes().size()},
                          {"gaussians", mapper.total_gaussians()},
                          {"refining", refining}};
  };
  const auto commit_interrupted = [&](size_t next, bool refining) {
    mapper.checkpoint(state(next, false), /*behind=*/false, timeline_member());
    return nlohmann::json{{"interrupted", where_stopped(next, refining)}};
  };
  if (interrupted) return commit_interrupted(next_frame, false);
  const size_t done = stopped_at ? *stopped_at + 1 : n;  // frames the map covers
  // The folder keeps what the run committed, and a new run into it is refused as into any map, while
  // --resume would end the same way: say so, or the next command is a second puzzle.
  // Before its first checkpoint the folder holds no map (map_state.hpp), and a new run starts there afresh.
  const auto left_as_is = [&] {
    return holds_a_map(o.out) ? cat("; ", o.out.string(), " is left with that empty map: remove it, or choose "
                                    "another --out, before running again")
                              : cat("; nothing was committed to ", o.out.string(), " (a new run there starts afresh)");
  };
  if (mapper.keyframes().empty()) {
    const std::string why = feed->why_no_pose();
    fail("dataset ", o.dataset, ": no frame with a pose became a keyframe", why.empty() ? "" : "; " + why, left_as_is());
  }
  if (mapper.total_gaussians() == 0 && mapper.refused_gaussians() > 0)
    fail("--budget ", cfg.residency.budget_gaussians, ": the map is empty, as every new Gaussian (",
         mapper.refused_gaussians(), ") was refused because its chunk could not hold it under the budget; a "
         "budget of at least ", mapper.largest_refusal(), " holds the largest of them, and a budget that holds "
         "whole views (several times that) maps well", left_as_is());
  // An empty map scored as if it were one (4 dB held-out, exit 0) hid the cause behind a warning.
  if (multiview && mapper.total_gaussians() == 0)
    fail("dataset ", o.dataset, ": no keyframe got depth from its neighbours (one camera needs two keyframes that "
         "see the same textured scene from places apart; the camera moved ", std::round((base.path_m + path_m) * 1000) / 1000,
         " m over its ", done, done == 1 ? " frame" : " frames", "), so the map is empty", left_as_is());
  nlohmann::json refinement;  // the steps after the last frame, when there were any
  if (!(prev.is_object() && prev.value("finished", false)) || start < n) {
    const uint64_t refine_steps = mapper.refinement_steps();
    Progress refine("refining", (long long)refine_steps);
    const auto t0 = std::chrono::steady_clock::now();
    const Mapper::StepTimes steps_before = mapper.step_times();
    const IoStats io_before = mapper.io_stats();
    const Mapper::RefineStats r = mapper.refine(refine_steps, [&](uint32_t) { refine.step(); }, stop_asked);
    refine.finish();
    if (stop_asked()) return commit_interrupted(done, true);  // --resume refines again
    if (r.steps > 0) {
      const double seconds = ms_since(t0) / 1000;
      const IoStats io = mapper.io_stats() - io_before;
      refinement = refinement_report(r, seconds, mapper.step_times() - steps_before, io);
      if (io.pool_loads > 0)
        log::info("refinement: ", r.steps, " steps over ", r.groups, " groups in ", seconds,
                  " s; ", io.pool_loads, " chunk loads (", io.sync_loads, " waited for, ", io.wait_ms,
                  " ms), ", io.evictions_dirty, " written back; pool copies ", io.evict_copy_ms, " ms out, ",
                  io.upload_ms, " ms in");
    }
  }
  record(done ? done - 1 : 0);
  double final_checkpoint_ms = 0;
  timed(final_checkpoint_ms,
        [&] { mapper.checkpoint(state(done, !stopped_at), /*behind=*/false, timeline_member()); });
  const std::vector<std::optional<SE3>> poses = feed->final_poses();
  Trajectory traj;  // the poses the map was made on (after every correction), TUM format
  for (size_t i = 0; i < std::min(done, poses.size()); ++i)
    if (poses[i]) traj.push_back(dataset->timestamp(i), *poses[i]);
  // A tracker with one camera: its unit is its own, and the file says so (eval ate then aligns with Sim(3)).
  write_tum_trajectory(o.out / "trajectory.txt", traj, own_unit);
  // The last sample sees the run as it ends (after the final checkpoint), so the plot, the CSV and
  // the report's times agree.
  disk_measured_at = -1e9;
  record(done ? done - 1 : 0);
  const double map_seconds = timeline.back().seconds;
  const double io_wait_ms = timeline.back().wait_ms;

  nlohmann::json report;
  report["dataset"] = o.dataset;
  report["poses"] = o.poses;
  report["frames"] = n;
  if (stopped_at)
    report["stopped"] = {{"frame", *stopped_at},
                         {"reason", "in_core_only: the map outgrew the budget"},
                         {"gaussians", mapper.total_gaussians()}};
  report["resolution"] = {info.camera.width * mc.resolution, info.camera.height * mc.resolution};
  report["depth"] = depth_mode_name(mode);
  if (multiview) report["multiview"] = multiview_report(*multiview, mapper);
  if (mapper.depth_refinement() > 0) {
    const SampleRefineTotals& r = mapper.refine_totals();
    report["depth_refinement"] = {{"inv_range", mapper.depth_refinement()},
                                  {"samplings", r.samplings},
                                  {"without_neighbour", r.without_neighbour},
                                  {"pixels", r.asked},
                                  {"refined", r.refined},
                                  {"refined_share", r.asked ? double(r.refined) / double(r.asked) : 0.0},
                                  {"mean_ms", r.samplings ? r.ms / double(r.samplings) : 0.0}};
  }
  if (learned_prior)
    report["learned_depth"] = {{"model", learned->describe()},
                               {"aligned_keyframes", learned_prior->aligned()},
                               {"fallback_keyframes", learned_prior->refused()}};
  report["settings"] = {{"pacing", mc.pacing},
                        {"iterations_per_keyframe", mc.iterations_per_keyframe},
                        {"final_iterations", mc.final_iterations},
                        {"speed", mc.speed},
                        {"holdout_every", mc.holdout_every},
                        {"budget_gaussians", cfg.residency.budget_gaussians},
                        {"chunk_size_m", cfg.store.chunk_size},
                        {"lambda_depth", cfg.loss.lambda_depth},
                        {"lr_position", mapper_cfg.adam.lr_position},
                        {"lr_small_image_factor", cfg.adam.small_image_factor(width, height)},
                        {"lr_reference_steps", cfg.adam.reference_steps},
                        {"lr_steps_factor", mapper.rate_steps_factor()},
                        {"sampler_density", cfg.sampler.density},
                        {"low_pass_px2", cfg.raster.low_pass_for(width, height)},
                        {"antialias", cfg.raster.antialias},
                        {"seed", mc.seed}};
  report["device"] = mapper.device();
  if (tracked) report["tracking"] = feed->report();
  report["pose_updates"] = updates.report();
  report["keyframes"] = mapper.keyframes().size();
  report["keyframes_without_depth"] = mapper.keyframes_without_depth();
  const uint64_t refined = refinement.is_null() ? 0 : refinement.value("steps", uint64_t(0));
  report["pacing"] = pacing_report(mapper, timeline, mc.min_steps_per_keyframe, refined);
  if (!refinement.is_null()) report["refinement"] = refinement;
  report["iterations"] = mapper.iterations();
  if (mapper.step_times().steps) report["step_ms"] = step_report(mapper.step_times());
  report["time"] = {{"mapping_s", map_seconds},
                    {"processing_fps", map_seconds > 0 ? double(done) / map_seconds : 0},
                    // Everything the optimiser thread lost to I/O (chunks, checkpoints, keyframes).
                    {"io_wait_ms", io_wait_ms},
                    {"io_wait_share", map_seconds > 0 ? io_wait_ms / 1000.0 / map_seconds : 0}};
  {
    // Where the optimiser thread's mapping time went: steps, keyframes (the sampler's render, its
    // draws, handing them to residency), waiting for frames, timeline samples, checkpoints and pose
    // updates. What is left is the loop's own overhead.
    const Mapper::KeyframeTimes& k = mapper.keyframe_times();
    report["time"]["optimiser_ms"] = {{"steps", mapper.step_times().total_ms},
                                      {"keyframes", k.total_ms},
                                      {"keyframe_render", k.render_ms},
                                      {"keyframe_sample", k.sample_ms},
                                      {"keyframe_add", k.add_ms},
                                      {"frame_wait", frames_wait_ms},
                                      {"timeline", record_ms},
                                      {"checkpoints", checkpoint_call_ms},
                                      {"final_checkpoint", final_checkpoint_ms},
                                      {"pose_updates", updates_ms}};
  }
  {
    // Distance covered, for drives: the intake rate in km/h is what the paper's settings name.
    const double path_m = traj.path_length();
    report["time"]["path_km"] = path_m / 1000.0;
    report["time"]["processing_kmh"] = map_seconds > 0 ? path_m / map_seconds * 3.6 : 0;
    const double span = done > 1 ? (dataset->timestamp(done - 1) - stamp0) / mc.speed : 0;
    if (mc.pacing == "anytime" && span > 0) report["time"]["intake_kmh"] = path_m / span * 3.6;
  }
  const IoStats io = mapper.io_stats();
  report["gaussians"] = {{"total", mapper.total_gaussians()},
                         {"peak_resident", mapper.peak_resident_gaussians()},
                         {"budget", mapper.budget()},
                         {"chunks", mapper.chunk_count()},
                         {"pruned", mapper.pruned_total()}};
  // New Gaussians a chunk could not take under the budget (a budget below one chunk's worth).
  report["gaussians"]["refused_over_budget"] = mapper.refused_gaussians();
  if (mapper.refused_gaussians()) report["gaussians"]["least_budget_for_refused"] = mapper.largest_refusal();
  // New chunks' picks too few for a chunk file: held back, then made into chunks or forgotten.
  report["gaussians"]["stray_picks"] = {{"held_back", mapper.strays_held_back()},
                                        {"made_into_chunks", mapper.strays_released()},
                                        {"forgotten", mapper.strays_forgotten()}};
  const DiskUsage du = disk_usage(o.out);
  report["disk"] = {{"files", du.files}, {"bytes", du.bytes}, {"allocated_bytes", du.allocated_bytes}};
  report["memory"] = memory_report(mapper, timeline);
  report["chunk_io"] = chunk_io_report(io, map_seconds);
  report["keyframe_io"] = keyframe_io_report(mapper.keyframe_io_stats());
  // Stopped while scoring: the map is finished and committed; the report says so instead of a score,
  // and --resume scores the map again.
  if (o.evaluate && !score_run(mapper, *dataset, poses, done, mc, o.out, lpips, report, stop_asked)) {
    report["interrupted"] = where_stopped(done, false);
    report["interrupted"]["scoring"] = true;
  }
  write_text(o.out / "timeline.csv", timeline_csv(timeline));
  write_timeline_plot(o.out / "memory.png", timeline, mapper.budget(), refined);
  write_json(o.out / "report.json", report);
  log::info("map ", o.out.string(), ": ", mapper.total_gaussians(), " Gaussians in ", mapper.chunk_count(),
            " chunks, ", mapper.keyframes().size(), " keyframes, ", map_seconds, " s (", io.summary(), ")");
  return report;
}

}  // namespace chungs
