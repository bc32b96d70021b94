// Where `run --resume` goes on: the checks that the command continues the map it names (same dataset,
// same poses and resolution, no fewer frames than it covers) and what the run carries over (its frame,
// time, timeline).
#pragma once
#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/pipeline/timeline.hpp"

namespace chungs {

struct ResumePoint {
  size_t start = 0;      // the first frame still to map
  double seconds = 0;    // run time of the parts before
  std::vector<TimelineSample> timeline;
};

// `state`: the run state the map was committed with (null for a new map: frame 0). `frames`: the
// dataset's frames; `mapped`: those this run maps (--max-frames); `resolution`: this run's image scale.
// Throws Error naming the flag or file.
ResumePoint resume_point(const RunOptions& o, const nlohmann::json& state, size_t frames, size_t mapped,
                         double resolution);

// The resolution a committed map was made at when it differs from `resolution` (the ROS node's check as
// well as run's); none when they agree or the state does not say (maps committed before it did).
std::optional<double> other_resolution(const nlohmann::json& state, double resolution);

}  // namespace chungs
