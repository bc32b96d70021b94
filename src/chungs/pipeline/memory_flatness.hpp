// Whether memory stayed flat once the map outgrew its budget: the check the paper's Figure 6 makes
// by eye (host RSS and VRAM level while the map keeps growing), computed from a run's timeline so
// that every report states it in numbers.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "chungs/pipeline/timeline.hpp"

namespace chungs {

struct Flatness {
  double plateau_mb = 0;    // median of the samples after the budget was reached
  double max_above = 0;     // largest (value - plateau) / plateau, >= 0
  double max_below = 0;     // largest (plateau - value) / plateau, >= 0
  double within_share = 0;  // share of samples within `tolerance` of the plateau
  // Seconds from the budget being reached until every later sample is within `tolerance` (the
  // bounded buffers for chunks in flight fill only once evicted chunks come back); -1: never.
  double settled_after_s = -1;
  size_t samples = 0;
};

struct MemoryFlatness {
  double reached_seconds = 0;                       // first sample whose resident count reached the budget
  // First sample with as many keyframes as host memory keeps images of (keyframes.max_in_memory); none
  // when the run never made that many.
  std::optional<double> keyframes_held_seconds;
  double from_seconds = 0;                          // where the samples measured start
  uint64_t total_at_reached = 0, total_at_end = 0;  // the map's Gaussians then and at the end
  double tolerance = 0.05;
  Flatness rss;
  std::optional<Flatness> vram;  // only when the run sampled device memory
  nlohmann::json to_json() const;
};

// The budget counts as reached at the first sample with resident >= reach_fraction * budget
// (residency keeps a little headroom below the budget). None when it never was, or when fewer than
// two samples follow. The samples measured start there, or later where the map reaches
// `keyframes_held` keyframes (0: not looked at) after it and two samples or more follow: host memory
// holds the images of that many keyframes, so RSS grows until then however level the Gaussians keep
// it (the paper's plateau is "once 1.5 M Gaussians and 400 keyframes are resident"). On a 2 km
// street at a 12 k budget the budget was reached at 10 s and the 400th keyframe came at 120 s: RSS
// rose 150 -> 235 MB between, then stayed within 1 % (bench/README.md, issue 19).
std::optional<MemoryFlatness> memory_flatness(const std::vector<TimelineSample>& samples, uint64_t budget,
                                              uint64_t keyframes_held = 0, double tolerance = 0.05,
                                              double reach_fraction = 0.95);

}  // namespace chungs
