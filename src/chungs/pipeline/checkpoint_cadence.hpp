// When the next resume point (a checkpoint written behind the optimiser) is due.
#pragma once
#include <cstddef>

#include "chungs/mapping/mapper_config.hpp"
#include "chungs/store/io_stats.hpp"

namespace chungs {

struct CheckpointCadence {
  double every_seconds = 30;   // 0: off
  int every_keyframes = 0;     // 0: off
  double max_share = 0.01;     // of the run's time, every checkpoint's cost to the optimiser together (0: no bound)
};

struct CheckpointClock {
  double seconds_since_last = 0;
  size_t keyframes_since_last = 0;
  double run_seconds = 0;          // this process's mapping so far
  double cost_ms = 0;              // what this process's checkpoints cost the optimiser so far
  double final_estimate_ms = 0;    // what the final checkpoint, which the run waits for, is expected to cost
};

// Due by time or keyframes, unless the checkpoints so far plus the final one would pass the share:
// bounding each checkpoint against the time since the last left the final one outside the bound, and
// a short run ended above it (2 km at 72 km/h on an H100: 2.17 % of the time, 1.4 s of it the final).
bool checkpoint_due(const CheckpointCadence& c, const CheckpointClock& t);

// The final checkpoint writes what changed since the last one, about what a checkpoint behind the
// optimiser writes from its start to its commit: their mean duration (0 before any has finished).
double final_checkpoint_estimate_ms(double behind_ms_total, size_t behind_count);

// The rule as `run` and the ROS node ask it: the settings' cadence, this process's checkpoint costs.
bool checkpoint_due(const MapperConfig& mc, double seconds_since_last, size_t keyframes_since_last,
                    double run_seconds, const IoStats& io);

}  // namespace chungs
