#include "chungs/pipeline/memory_flatness.hpp"

#include <algorithm>
#include <cmath>

namespace chungs {

namespace {

Flatness flatness_of(const std::vector<double>& v, const std::vector<double>& t, double tolerance) {
  Flatness f;
  f.samples = v.size();
  std::vector<double> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  const size_t n = sorted.size();
  f.plateau_mb = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  if (f.plateau_mb <= 0) return f;
  size_t within = 0;
  for (double x : v) {
    const double d = (x - f.plateau_mb) / f.plateau_mb;
    f.max_above = std::max(f.max_above, d);
    f.max_below = std::max(f.max_below, -d);
    if (std::abs(d) <= tolerance) ++within;
  }
  f.within_share = double(within) / double(n);
  for (size_t i = n; i-- > 0;) {
    if (std::abs(v[i] - f.plateau_mb) > tolerance * f.plateau_mb) break;
    f.settled_after_s = t[i] - t[0];
  }
  return f;
}

nlohmann::json flat_json(const Flatness& f) {
  return {{"plateau_mb", f.plateau_mb},
          {"max_above", f.max_above},
          {"max_below", f.max_below},
          {"within_share", f.within_share},
          {"settled_after_s", f.settled_after_s},
          {"samples", f.samples}};
}

}  // namespace

nlohmann::json MemoryFlatness::to_json() const {
  nlohmann::json j = {{"reached_seconds", reached_seconds},
                      {"keyframes_held_seconds", keyframes_held_seconds ? nlohmann::json(*keyframes_held_seconds)
                                                                        : nlohmann::json(nullptr)},
                      {"from_seconds", from_seconds},
                      {"total_at_reached", total_at_reached},
                      {"total_at_end", total_at_end},
                      {"tolerance", tolerance},
                      {"rss", flat_json(rss)}};
  if (vram) j["vram"] = flat_json(*vram);
  return j;
}

std::optional<MemoryFlatness> memory_flatness(const std::vector<TimelineSample>& samples, uint64_t budget,
                                              uint64_t keyframes_held, double tolerance, double reach_fraction) {
  if (budget == 0) return std::nullopt;
  const auto reached = std::find_if(samples.begin(), samples.end(), [&](const TimelineSample& s) {
    return double(s.resident) >= reach_fraction * double(budget);
  });
  if (samples.end() - reached < 2) return std::nullopt;
  MemoryFlatness m;
  m.tolerance = tolerance;
  m.reached_seconds = reached->seconds;
  m.total_at_reached = reached->total;
  m.total_at_end = samples.back().total;
  auto from = reached;
  if (keyframes_held > 0) {
    const auto held = std::find_if(samples.begin(), samples.end(),
                                   [&](const TimelineSample& s) { return s.keyframes >= keyframes_held; });
    if (held != samples.end()) {
      m.keyframes_held_seconds = held->seconds;
      if (held > reached && samples.end() - held >= 2) from = held;
    }
  }
  m.from_seconds = from->seconds;
  std::vector<double> rss, vram, t;
  bool sampled_vram = false;
  for (auto it = from; it != samples.end(); ++it) {
    t.push_back(it->seconds);
    rss.push_back(it->rss_mb);
    vram.push_back(it->vram_mb);
    sampled_vram = sampled_vram || it->vram_mb > 0;
  }
  m.rss = flatness_of(rss, t, tolerance);
  if (sampled_vram) m.vram = flatness_of(vram, t, tolerance);
  return m;
}

}  // namespace chungs
