// What the mapper's memory, map size and chunk I/O did over a run: one sample per keyframe, written
// as CSV and drawn as a PNG plot against time (like the paper's Figure 6).
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>

#include "chungs/common/text_pieces.hpp"
#include <string>
#include <vector>

namespace chungs {

struct TimelineSample {
  double seconds = 0;  // since the start of the run (summed over resumed parts)
  uint64_t frame = 0, keyframes = 0, iterations = 0;
  uint64_t resident = 0, total = 0, chunks = 0;
  double rss_mb = 0;
  uint64_t loads = 0, saves = 0;
  double io_ms = 0;                    // chunk load + save time (any thread)
  double read_mb = 0, written_mb = 0;  // chunk bytes moved
  double wait_ms = 0;  // time the optimiser was blocked on chunk I/O (loads, full queues, checkpoints)
  double disk_mb = 0;  // the map folder's size on disk
  double vram_mb = 0;  // device memory in use (0 on a CPU run)
  // Whether the optimiser kept up with the intake (cumulative since the run began).
  uint64_t sampled = 0, pruned = 0;  // Gaussians added by the sampler, removed by pruning
  uint64_t dropped = 0;              // keyframes dropped because a later one was already loaded
  double checkpoint_ms = 0;          // optimiser time spent on checkpoints (part of wait_ms)
  double path_m = 0;                 // distance the camera travelled
};

std::string timeline_csv(const std::vector<TimelineSample>& samples);
nlohmann::json to_json(const std::vector<TimelineSample>& samples);
// The same as JSON text, appended: what a checkpoint writes, without building the tree (see
// KeyframeChunkIndex::append_json).
void append_json(TextPieces& out, const std::vector<TimelineSample>& samples);
std::vector<TimelineSample> timeline_from_json(const nlohmann::json& j);

// Four stacked panels against time (minutes for runs over three minutes, else seconds):
// Gaussians (total, resident, on disk, budget), memory (host RSS, VRAM when sampled), chunk I/O
// (cumulative loads and saves, map folder size on a right axis, the optimiser's I/O wait share) and
// the steps each keyframe got (with the keyframes dropped and the checkpoints' share of the time).
// refinement_steps: the steps after the last frame, in the last samples (pacing_summary).
void write_timeline_plot(const std::filesystem::path& file, const std::vector<TimelineSample>& samples,
                         uint64_t budget, uint64_t refinement_steps = 0);

// Where write_timeline_plot puts its panels' plot areas (pixels, inclusive), so tests can look inside.
struct TimelinePlotBox {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
struct TimelinePlotLayout {
  int width = 0, height = 0;
  TimelinePlotBox gaussians, memory, io, steps;
};
TimelinePlotLayout timeline_plot_layout();

}  // namespace chungs
