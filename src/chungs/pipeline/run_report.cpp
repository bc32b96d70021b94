#include "chungs/pipeline/run_report.hpp"

#include <algorithm>
#include <cstdio>

#include "chungs/common/error.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/pipeline/memory_flatness.hpp"
#include "chungs/pipeline/pacing_summary.hpp"

namespace chungs {

nlohmann::json pacing_report(const Mapper& mapper, const std::vector<TimelineSample>& timeline,
                             int min_steps_per_keyframe, uint64_t refinement_steps) {
  // Whether the optimiser kept up: the figures a starving run shows first.
  nlohmann::json pj = pacing_summary(timeline, refinement_steps).to_json();
  pj["min_steps_per_keyframe"] = min_steps_per_keyframe;
  pj["views_over_budget"] = mapper.views_over_budget();
  if (mapper.views_over_budget()) pj["largest_view_gaussians"] = mapper.largest_view();
  if (const Mapper::WindowStats& w = mapper.window_stats(); w.updates) {
    // How much of the selection cell the budget left trainable.
    const double n = double(std::max<uint64_t>(w.narrowed, 1));
    const double steps = double(std::max<uint64_t>(mapper.iterations(), 1));
    pj["training_window"] = {{"narrowed_share", double(w.narrowed) / double(w.updates)},
                             {"mean_keyframes", w.keyframes / n},
                             {"mean_cell_keyframes", w.cell_keyframes / n},
                             {"mean_reach_m", w.reach_m / n},
                             {"partial_step_share", double(w.partial_steps) / steps},
                             {"partial_too_small", w.partial_too_small},
                             {"trimmed_step_share", double(w.trimmed_steps) / steps},
                             {"best_view_step_share", double(w.best_view_steps) / steps},
                             {"beyond_core_step_share", double(w.beyond_core_steps) / steps}};
  }
  if (const Mapper::WindowStats& w = mapper.window_stats(); w.revisit_bursts) {
    const double steps = double(std::max<uint64_t>(mapper.iterations(), 1));
    pj["revisits"] = {{"step_share", double(w.revisit_steps) / steps}, {"bursts", w.revisit_bursts}};
  }
  return pj;
}

std::string pacing_line(const nlohmann::json& report) {
  const nlohmann::json& p = report["pacing"];
  // The floor binds only a real-time intake; fixed pacing gives every keyframe its --iterations.
  const bool anytime = report["settings"].value("pacing", std::string()) == "anytime";
  const std::string bound = anytime ? cat("floor ", p["min_steps_per_keyframe"].get<int>())
                                    : cat("fixed at ", report["settings"].value("iterations_per_keyframe", 0));
  char line[512];
  std::snprintf(line, sizeof line,
                "pacing: %.1f steps per keyframe (lowest minute %.1f, %s), %llu keyframes dropped, checkpoints "
                "%.2f %% of the time, I/O wait %.2f %%",
                p["steps_per_keyframe_mean"].get<double>(), p["steps_per_keyframe_lowest_minute"].get<double>(),
                bound.c_str(), p["dropped_keyframes"].get<unsigned long long>(),
                100 * p["checkpoint_share"].get<double>(), 100 * report["time"]["io_wait_share"].get<double>());
  std::string out = line;
  if (p.value("path_m", 0.0) >= PacingSummary::kMinPathForRates_m)
    std::snprintf(line, sizeof line, "; per 100 m: %.0f Gaussians sampled, %.0f pruned",
                  p["sampled_per_100m"].get<double>(), p["pruned_per_100m"].get<double>());
  else
    std::snprintf(line, sizeof line, "; %llu Gaussians sampled, %llu pruned over %.2f m", p.value("sampled", 0ull),
                  p.value("pruned", 0ull), p.value("path_m", 0.0));
  return out + line;
}

std::string training_window_line(const nlohmann::json& pacing) {
  if (!pacing.contains("training_window")) return {};
  const nlohmann::json& w = pacing["training_window"];
  const double narrowed = w.value("narrowed_share", 0.0);
  if (!(narrowed > 0)) return {};
  // The count of views trained together is what a budget costs the map (bench/README, issue 19: at the
  // same radius, 170 / 300 / 400 of them scored 25.8 / 26.3 / 26.5 dB on a 2 km street that loops), so
  // a user choosing a budget is told how many it held.
  char line[512];
  std::snprintf(line, sizeof line,
                "training window: the budget narrowed training %.0f %% of the time, to %.0f of %.0f candidate "
                "keyframes on average (%.0f m around the latest); %.1f %% of the steps trained a keyframe outside it "
                "on its resident chunks. Fewer views trained together give a lower map where a route passes a place "
                "again; a larger --budget holds more of them.",
                100 * narrowed, w.value("mean_keyframes", 0.0), w.value("mean_cell_keyframes", 0.0),
                w.value("mean_reach_m", 0.0), 100 * w.value("partial_step_share", 0.0));
  return line;
}

nlohmann::json step_report(const Mapper::StepTimes& t) {
  // Per step, on the optimiser thread: drawing the next keyframe and reading its chunks ahead (pick,
  // outside `mean`), culling and pinning its chunks, the backend's render, loss, backward and Adam
  // (keyframe loads included), and the rest (dirty marks, pruning's bookkeeping).
  const double n = double(t.steps);
  return {{"mean", t.total_ms / n},
          {"pick", t.pick_ms / n},
          {"cull", t.cull_ms / n},
          {"pin", t.pin_ms / n},
          {"chunks", t.chunks_ms / n},
          {"backend", t.backend_ms / n},
          {"keyframe_load", t.keyframe_load_ms / n},
          {"keyframe_loads_per_step", double(t.keyframe_loads) / n},
          {"bookkeeping", (t.total_ms - t.chunks_ms - t.backend_ms) / n}};
}

nlohmann::json memory_report(const Mapper& mapper, const std::vector<TimelineSample>& timeline) {
  double peak_rss = 0;
  for (const auto& t : timeline) peak_rss = std::max(peak_rss, t.rss_mb);
  nlohmann::json m = {{"peak_rss_mb_sampled", peak_rss},
                      {"peak_rss_mb_process", double(peak_rss_bytes()) / 1048576.0}};
  if (const auto dm = mapper.device_memory()) {
    double peak_vram = 0;
    for (const auto& t : timeline) peak_vram = std::max(peak_vram, t.vram_mb);
    // Device-wide (cudaMemGetInfo): includes the CUDA context and any other process on the GPU.
    m["vram_used_mb_peak_sampled"] = peak_vram;
    m["vram_used_mb_end"] = dm->used_mb;
    m["vram_total_mb"] = dm->total_mb;
  }
  // The host memory for chunks in flight (residency/host_block_pool.hpp): its size, the most of it
  // in use, and blocks that found no room in it and came from the heap (which can grow RSS).
  const HostBlockPool& blocks = mapper.in_flight_blocks();
  m["in_flight_pool"] = {{"capacity_mb", double(blocks.capacity_bytes()) / 1048576.0},
                         {"peak_used_mb", double(blocks.peak_used_bytes()) / 1048576.0},
                         {"resident", blocks.resident()},
                         {"heap_blocks", blocks.heap_blocks()}};
  // Once the budget is reached (and the keyframe images host memory keeps), memory should stay level
  // however far the map grows.
  if (const auto flat = memory_flatness(timeline, mapper.budget(), mapper.config().keyframes.max_in_memory))
    m["after_budget"] = flat->to_json();
  return m;
}

nlohmann::json chunk_io_report(const IoStats& io, double map_seconds) {
  return {{"loads", io.loads},
          {"saves", io.saves},
          {"mean_load_ms", io.mean_load_ms()},
          {"mean_save_ms", io.mean_save_ms()},
          {"io_time_share", map_seconds > 0 ? (io.load_ms + io.save_ms) / 1000.0 / map_seconds : 0},
          // The optimiser's own loss to I/O: blocking loads, full write queues and checkpoints. The
          // background thread's time (io_time_share) overlaps with training and is not a cost by itself.
          {"wait_time_share", map_seconds > 0 ? io.optimiser_wait_ms() / 1000.0 / map_seconds : 0},
          {"wait_ms", io.wait_ms},
          {"write_wait_ms", io.write_wait_ms},
          {"checkpoints", io.checkpoints},
          {"checkpoint_ms", io.checkpoint_ms},
          {"checkpoints_behind", io.checkpoints_behind},
          {"checkpoint_behind_ms", io.checkpoint_behind_ms},
          // Of the checkpoints the run waits for (the final one): gathering out of the pool and the
          // commit; what is left of their time is writing the files.
          {"flush_gather_ms", io.flush_gather_ms},
          {"flush_commit_ms", io.flush_commit_ms},
          {"barrier_ms", io.barrier_ms},
          {"bytes_read", io.bytes_read},
          {"bytes_written", io.bytes_written},
          // Chunks made resident, and how: read ahead in the background, or waited for by the optimiser.
          {"pool_loads", io.pool_loads},
          {"prefetch_hits", io.prefetch_hits},
          {"waited_loads", io.sync_loads},
          {"evictions_clean", io.evictions_clean},
          {"evictions_dirty", io.evictions_dirty},
          // The optimiser thread's copies out of the pool (evictions) and into it (loads).
          {"evict_copy_ms", io.evict_copy_ms},
          {"upload_ms", io.upload_ms},
          {"evicting_ms", io.evicting_ms},
          {"loading_ms", io.loading_ms},
          {"take_ms", io.take_ms},
          {"take_lock_ms", io.take_lock_ms},
          {"read_ahead_full", io.read_ahead_full},
          {"read_ahead_no_room", io.read_ahead_no_room},
          {"reader_writes", io.reader_writes},
          {"summary", io.summary()}};
}

nlohmann::json refinement_report(const Mapper::RefineStats& r, double seconds, const Mapper::StepTimes& steps,
                                 const IoStats& io) {
  // The whole map streams through the budget here, so this is where chunk I/O weighs most: its
  // counters over the refinement alone, its shares of the refinement's time.
  nlohmann::json j = {
      {"steps", r.steps}, {"groups", r.groups}, {"seconds", seconds}, {"chunk_io", chunk_io_report(io, seconds)}};
  if (steps.steps) j["step_ms"] = step_report(steps);
  return j;
}

nlohmann::json keyframe_io_report(const IoStats& kio) {
  return {{"loads", kio.loads},
          {"saves", kio.saves},
          {"mean_load_ms", kio.mean_load_ms()},
          {"mean_save_ms", kio.mean_save_ms()},
          {"read_ahead", kio.prefetch_hits},
          {"read_on_demand", kio.sync_loads},
          {"waits", kio.waits},
          {"wait_ms", kio.wait_ms},
          {"barrier_ms", kio.barrier_ms},
          {"bytes_read", kio.bytes_read},
          {"bytes_written", kio.bytes_written}};
}

}  // namespace chungs
