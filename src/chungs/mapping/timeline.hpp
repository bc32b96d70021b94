// What the mapper's memory and map size did over a run: one sample per keyframe, written as CSV
// and drawn as a PNG plot (the paper's Figure 6: resident vs total Gaussians and process memory).
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

namespace chungs {

struct TimelineSample {
  double seconds = 0;  // since the start of the run (summed over resumed parts)
  uint64_t frame = 0, keyframes = 0, iterations = 0;
  uint64_t resident = 0, total = 0, chunks = 0;
  double rss_mb = 0;
  uint64_t loads = 0, saves = 0;
  double io_ms = 0;  // chunk load + save time (any thread)
  double read_mb = 0, written_mb = 0;  // chunk bytes moved
  double wait_ms = 0;  // time the optimiser was blocked on chunk I/O (loads, full queues, checkpoints)
  double disk_mb = 0;  // the map folder's size on disk
};

std::string timeline_csv(const std::vector<TimelineSample>& samples);
nlohmann::json to_json(const std::vector<TimelineSample>& samples);
std::vector<TimelineSample> timeline_from_json(const nlohmann::json& j);

// Line plot: resident and total Gaussians (left axis, thousands) and RSS (right axis, MB) against
// keyframes, with axes, ticks and a legend.
void write_timeline_plot(const std::filesystem::path& file, const std::vector<TimelineSample>& samples, uint64_t budget);

}  // namespace chungs
