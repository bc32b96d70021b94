// Loop closure in the map, on the synthetic room (RGB-D; the trajectory returns to its start).
// The room is mapped several ways and scored on held-out frames (every 8th) rendered at the
// ground-truth poses:
//   gt             mapped on ground-truth poses from the start;
//   drifted        mapped on a drifted trajectory (a small rotation and translation error added per
//                  frame, in proportion to the distance travelled), never corrected;
//   corrected      the drifted run, then one loop-closure event at the last frame moves every keyframe
//                  to its ground-truth pose (Mapper::correct_poses), refines the junction, and goes on;
//   corrected_seq  the same with batching off (chunk by chunk);
//   gt_event       (not run by default) ground-truth poses and the same loop-closure event with no pose
//                  change: the junction is reset and refined as in `corrected`, so the two differ only
//                  in the poses the map was built on.
// All make the same number of optimisation steps. Also times the correction in batch and chunk by
// chunk, and replays the event on a copy of the map reopened under a budget of a quarter of the map
// (chunks loaded from and written to disk).
//
//   bench_loop_correction [--frames 132] [--rate 6] [--width 160] [--iters 10] [--final 300] [--refine 200]
//                         [--drift 0.02] [--yaw-deg-per-m 0.5] [--chunk 1.0] [--seeds 1] [--first-seed 1]
//                         [--runs gt,drifted,corrected,corrected_seq]
//                         [--out result.json]
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include "chungs/common/log.hpp"
#include "chungs/pipeline/evaluation.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/scene.hpp"
#include "chungs/synth/sequence.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

struct Args {
  size_t frames = 132;  // 1.1 loops at 6 Hz: the end revisits the start
  double rate = 6.0;    // frames per second of the 20 s loop
  int width = 160, iters = 10, final_iters = 300, refine = 200;
  double drift = 0.02, yaw_deg_per_m = 0.5, chunk = 1.0;
  int seeds = 1, first_seed = 1;  // each variant is mapped with seeds first_seed.. (seeds of them)
  std::string runs = "gt,drifted,corrected,corrected_seq";
  std::string out;
};

// The rendered room in memory, as a dataset.
class RoomFrames : public Dataset {
 public:
  RoomFrames(const Args& a) {
    synth::RoomOptions ro;
    ro.rate_hz = a.rate;
    synth::MeshScene scene(synth::build_room(ro), synth::Environment::indoor());
    const Trajectory traj = synth::room_trajectory(ro, a.frames);
    const Camera cam = synth::tum_camera(a.width, a.width * 3 / 4);
    info_.kind = "synthetic";
    info_.path = "room";
    info_.frames = a.frames;
    info_.camera = cam;
    info_.has_depth = info_.has_gt = info_.color = true;
    info_.rate_hz = ro.rate_hz;
    synth::Rasterizer r;
    synth::RenderOptions opt;
    opt.far = 30;
    for (size_t i = 0; i < a.frames; ++i) {
      synth::RenderedFrame rf;
      synth::render_frame(r, scene, cam, traj.poses[i], 0, opt, rf);
      Frame f;
      f.index = i;
      f.timestamp = traj.stamps[i];
      f.left = rf.left;
      f.depth = rf.depth;
      f.gt_pose = traj.poses[i];
      f.camera = cam;
      f.source = "room frame " + std::to_string(i);
      frames_.push_back(std::move(f));
    }
  }
  const DatasetInfo& info() const override { return info_; }
  double timestamp(size_t i) const override { return frames_.at(i).timestamp; }
  std::optional<SE3> gt_pose(size_t i) const override { return frames_.at(i).gt_pose; }
  Frame frame(size_t i) const override { return frames_.at(i); }

 private:
  DatasetInfo info_;
  std::vector<Frame> frames_;
};

// Ground truth with an accumulated error: per frame, a translation of `drift` times the distance
// travelled along a fixed direction and a yaw of yaw_deg_per_m per metre, composed on the left.
std::vector<SE3> drifted(const std::vector<SE3>& gt, double drift, double yaw_deg_per_m) {
  std::vector<SE3> out;
  SE3 err;
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 0.6, 0.2).normalized();
  for (size_t i = 0; i < gt.size(); ++i) {
    if (i > 0) {
      const double step = (gt[i].t - gt[i - 1].t).norm();
      // Rotating about the current position keeps the error local to the path.
      const SE3 about(Eigen::Quaterniond::Identity(), gt[i].t);
      const SE3 yaw(
          Eigen::Quaterniond(Eigen::AngleAxisd(yaw_deg_per_m * step * M_PI / 180, Eigen::Vector3d::UnitZ())),
          drift * step * dir);
      err = about * yaw * about.inverse() * err;
    }
    out.push_back(err * gt[i]);
  }
  return out;
}

Config room_config(const Args& a, uint64_t seed) {
  Config c;
  c.mapper.seed = seed;
  c.loss = LossConfig::indoor();
  c.adam.lr_position = 5e-5f;  // the paper's indoor rate, which this bench's recorded figures used
  c.store.chunk_size = a.chunk;
  c.store.durable = false;
  c.keyframes.durable = false;
  c.mapper.device = "auto";
  c.validate();
  return c;
}

struct RunResult {
  std::string device;
  double psnr = 0, ssim = 0, seconds = 0;
  uint64_t gaussians = 0, gaussians_at_event = 0, pruned = 0;
  size_t chunks = 0;
  PoseCorrectionStats corr;
  // The same correction replayed on a copy of the map reopened under a small budget (a quarter of
  // the map): chunk by chunk, with the chunks loaded from and written to disk.
  PoseCorrectionStats replay;
  size_t replay_budget = 0, replay_peak = 0;
  uint64_t replay_loads = 0, replay_saves = 0;
};

struct Variant {
  const char* key;
  const char* name;
  bool drifted_poses, correct, batch, replay;
};

// Maps every non-held-out frame as a keyframe on the variant's poses with `iters` steps each; with
// `correct`, the last keyframe closes the loop: all keyframes move to ground truth and the junction
// (the last keyframe and the first) is refined for `refine` steps; without, the same steps are
// plain steps.
RunResult run(const RoomFrames& data, const std::vector<SE3>& drifted_poses, const std::vector<SE3>& gt,
              const Args& a, const fs::path& folder, const Variant& v, uint64_t seed) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<SE3>& poses = v.drifted_poses ? drifted_poses : gt;
  const bool correct = v.correct, batch = v.batch;
  const Config c = room_config(a, seed);
  RunResult r;
  {
    Mapper m(folder, c, false);
    m.set_loop_batch_allowed(batch);
    r.device = m.device();
    std::vector<size_t> held;
    for (size_t i = 0; i < data.size(); ++i) {
      if (i % 8 == 7) {
        held.push_back(i);
        continue;
      }
      const Frame f = data.frame(i);
      m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, poses[i]);
      for (int k = 0; k < a.iters; ++k) m.step();
    }
    r.gaussians_at_event = m.total_gaussians();
    if (correct) {
      std::vector<std::pair<uint32_t, SE3>> fix;
      for (const auto& k : m.keyframes()) fix.emplace_back(k.id, gt[k.frame]);
      const std::vector<uint32_t> junction{m.keyframes().front().id, m.keyframes().back().id};
      if (v.replay) {
        m.checkpoint({});
        const fs::path copy = folder.string() + "_replay";
        fs::copy(folder, copy, fs::copy_options::recursive);
        Config small = c;
        small.residency.budget_gaussians = std::max<size_t>(1000, m.total_gaussians() / 4);
        {
          Mapper replay(copy, small, true);
          const IoStats io0 = replay.io_stats();
          r.replay = replay.correct_poses(fix, junction, 0);
          r.replay_budget = replay.budget();
          r.replay_peak = replay.peak_resident_gaussians();
          r.replay_loads = replay.io_stats().loads - io0.loads;
          r.replay_saves = replay.io_stats().saves - io0.saves;
        }
        fs::remove_all(copy);
      }
      r.corr = m.correct_poses(fix, junction, a.refine);
    } else {
      for (int k = 0; k < a.refine; ++k) m.step();
    }
    for (int k = 0; k < a.final_iters; ++k) m.step();
    std::vector<std::optional<SE3>> gt_opt(gt.begin(), gt.end());
    const ViewSetScore s = score_views(m, data, gt_opt, held, 1.0, {}, "", 0);
    r.psnr = s.mean_psnr;
    r.ssim = s.mean_ssim;
    r.gaussians = m.total_gaussians();
    r.pruned = m.pruned_total();
    r.chunks = m.chunk_count();
    m.checkpoint({});
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    Args a;
    for (int i = 1; i < argc; ++i) {
      const std::string k = argv[i];
      if (i + 1 >= argc) fail("option ", k, " needs a value");
      const char* v = argv[++i];
      if (k == "--frames")
        a.frames = std::stoul(v);
      else if (k == "--width")
        a.width = std::stoi(v);
      else if (k == "--rate")
        a.rate = std::stod(v);
      else if (k == "--iters")
        a.iters = std::stoi(v);
      else if (k == "--final")
        a.final_iters = std::stoi(v);
      else if (k == "--refine")
        a.refine = std::stoi(v);
      else if (k == "--drift")
        a.drift = std::stod(v);
      else if (k == "--yaw-deg-per-m")
        a.yaw_deg_per_m = std::stod(v);
      else if (k == "--chunk")
        a.chunk = std::stod(v);
      else if (k == "--seeds")
        a.seeds = std::stoi(v);
      else if (k == "--first-seed")
        a.first_seed = std::stoi(v);
      else if (k == "--runs")
        a.runs = v;
      else if (k == "--out")
        a.out = v;
      else
        fail("unknown option ", k);
    }
    log::set_level(log::Level::Warn);
    const RoomFrames data(a);
    std::vector<SE3> gt;
    double path = 0;
    for (size_t i = 0; i < data.size(); ++i) {
      gt.push_back(*data.gt_pose(i));
      if (i) path += (gt[i].t - gt[i - 1].t).norm();
    }
    const std::vector<SE3> dr = drifted(gt, a.drift, a.yaw_deg_per_m);
    const SE3 end_err = dr.back() * gt.back().inverse();
    std::printf(
        "room: %zu frames at %dx%d, path %.2f m; drift at the end %.3f m (%.2f %% of the path), %.2f deg\n",
        data.size(), a.width, a.width * 3 / 4, path, (dr.back().t - gt.back().t).norm(),
        100 * (dr.back().t - gt.back().t).norm() / path, end_err.angle() * 180 / M_PI);
    const Variant all[] = {
        {"gt", "gt poses", false, false, true, false},
        {"drifted", "drifted, uncorrected", true, false, true, false},
        {"corrected", "drifted, corrected", true, true, true, true},
        {"corrected_seq", "drifted, corrected (seq)", true, true, false, false},
        {"gt_event", "gt poses + event", false, true, true, false},
    };
    std::vector<Variant> chosen;
    for (size_t from = 0; from <= a.runs.size();) {
      const size_t to = std::min(a.runs.find(',', from), a.runs.size());
      const std::string key = a.runs.substr(from, to - from);
      const auto it =
          std::find_if(std::begin(all), std::end(all), [&](const Variant& v) { return key == v.key; });
      if (it == std::end(all)) fail("--runs: unknown run '", key, "'");
      chosen.push_back(*it);
      from = to + 1;
    }
    const fs::path tmp = fs::temp_directory_path() / ("chungs_bench_loop_" + std::to_string(::getpid()));
    fs::remove_all(tmp);
    std::vector<std::vector<RunResult>> res(chosen.size());
    const int last_seed = a.first_seed + a.seeds - 1;
    for (int seed = a.first_seed; seed <= last_seed; ++seed) {
      for (size_t v = 0; v < chosen.size(); ++v) {
        res[v].push_back(run(data, dr, gt, a, tmp / chosen[v].key, chosen[v], seed));
        const RunResult& r = res[v].back();
        std::fprintf(stderr, "seed %d %-26s PSNR %6.2f dB  %8llu Gaussians  %6.1f s\n", seed, chosen[v].name,
                     r.psnr, (unsigned long long)r.gaussians, r.seconds);
      }
      fs::remove_all(tmp);
    }
    std::printf("device %s; %d steps per keyframe, %d junction/extra steps, %d final steps, seeds %d..%d\n",
                res[0][0].device.c_str(), a.iters, a.refine, a.final_iters, a.first_seed, last_seed);
    nlohmann::json out{{"args",
                        {{"frames", a.frames},
                         {"rate", a.rate},
                         {"width", a.width},
                         {"iters", a.iters},
                         {"final", a.final_iters},
                         {"refine", a.refine},
                         {"drift", a.drift},
                         {"yaw_deg_per_m", a.yaw_deg_per_m},
                         {"chunk", a.chunk},
                         {"seeds", a.seeds},
                         {"first_seed", a.first_seed}}},
                       {"device", res[0][0].device}};
    for (size_t v = 0; v < chosen.size(); ++v) {
      double psnr = 0, ssim = 0;
      nlohmann::json runs = nlohmann::json::array();
      for (size_t i = 0; i < res[v].size(); ++i) {
        const RunResult& r = res[v][i];
        std::printf(
            "%-26s seed %d PSNR %6.2f dB  SSIM %.4f  %8llu Gaussians (%llu at the event, %llu pruned)  %4zu "
            "chunks"
            "  %6.1f s\n",
            chosen[v].name, a.first_seed + int(i), r.psnr, r.ssim, (unsigned long long)r.gaussians,
            (unsigned long long)r.gaussians_at_event, (unsigned long long)r.pruned, r.chunks, r.seconds);
        psnr += r.psnr / a.seeds;
        ssim += r.ssim / a.seeds;
        runs.push_back({{"seed", a.first_seed + int(i)},
                        {"psnr", r.psnr},
                        {"ssim", r.ssim},
                        {"gaussians", r.gaussians},
                        {"gaussians_at_event", r.gaussians_at_event},
                        {"pruned", r.pruned},
                        {"chunks", r.chunks},
                        {"seconds", r.seconds},
                        {"correction", r.corr.to_json()}});
      }
      std::printf("%-26s mean PSNR %6.2f dB  SSIM %.4f\n", chosen[v].name, psnr, ssim);
      out[chosen[v].key] = {{"mean_psnr", psnr}, {"mean_ssim", ssim}, {"runs", runs}};
    }
    for (size_t v = 0; v < chosen.size(); ++v)
      if (chosen[v].correct)
        for (const RunResult& r : res[v])
          std::printf(
              "correction (%s, %s): %zu keyframes, %zu Gaussians moved, %zu changed chunk, %zu chunks "
              "touched "
              "(%zu new), %zu junction Gaussians; apply %.1f ms, refine %.1f ms\n",
              chosen[v].key, r.corr.batch ? "batch" : "chunk by chunk", r.corr.keyframes,
              r.corr.gaussians_moved, r.corr.gaussians_changed_chunk, r.corr.chunks_touched,
              r.corr.chunks_created, r.corr.junction_gaussians, r.corr.apply_ms, r.corr.refine_ms);
    nlohmann::json replays = nlohmann::json::array();
    for (size_t v = 0; v < chosen.size(); ++v) {
      if (!chosen[v].replay) continue;
      for (const RunResult& r : res[v]) {
        std::printf(
            "replayed under a budget of %zu (peak resident %zu): %s, %zu Gaussians moved, %zu changed chunk, "
            "%llu chunk loads, %llu saves; apply %.1f ms\n",
            r.replay_budget, r.replay_peak, r.replay.batch ? "batch" : "chunk by chunk",
            r.replay.gaussians_moved, r.replay.gaussians_changed_chunk, (unsigned long long)r.replay_loads,
            (unsigned long long)r.replay_saves, r.replay.apply_ms);
        replays.push_back({{"budget", r.replay_budget},
                           {"peak_resident", r.replay_peak},
                           {"loads", r.replay_loads},
                           {"saves", r.replay_saves},
                           {"correction", r.replay.to_json()}});
      }
    }
    out["replay_small_budget"] = replays;
    if (!a.out.empty()) {
      FILE* f = std::fopen(a.out.c_str(), "w");
      if (!f) fail("cannot write ", a.out);
      std::fputs(out.dump(2).c_str(), f);
      std::fclose(f);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_loop_correction: %s\n", e.what());
    return 1;
  }
}
