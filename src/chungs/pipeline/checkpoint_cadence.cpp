#include "chungs/pipeline/checkpoint_cadence.hpp"

namespace chungs {

bool checkpoint_due(const CheckpointCadence& c, const CheckpointClock& t) {
  const bool due = (c.every_seconds > 0 && t.seconds_since_last >= c.every_seconds) ||
                   (c.every_keyframes > 0 && t.keyframes_since_last >= size_t(c.every_keyframes));
  if (!due || !(c.max_share > 0)) return due;
  return t.cost_ms + t.final_estimate_ms <= c.max_share * t.run_seconds * 1000.0;
}

double final_checkpoint_estimate_ms(double behind_ms_total, size_t behind_count) {
  return behind_count > 0 && behind_ms_total > 0 ? behind_ms_total / double(behind_count) : 0;
}

bool checkpoint_due(const MapperConfig& mc, double seconds_since_last, size_t keyframes_since_last,
                    double run_seconds, const IoStats& io) {
  return checkpoint_due({mc.checkpoint_seconds, mc.checkpoint_every, mc.checkpoint_max_share},
                        {seconds_since_last, keyframes_since_last, run_seconds, io.checkpoint_ms,
                         final_checkpoint_estimate_ms(io.checkpoint_behind_ms, io.checkpoints_behind)});
}

}  // namespace chungs
