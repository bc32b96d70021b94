// The ATE plot of `eval ate --plot` and `track` (issue 23): both trajectories from above after the
// alignment, and the position error along the path, as one PNG (apps/diskchungs/cmd_eval.cpp).
#pragma once
#include <string>

#include "chungs/eval/trajectory_metrics.hpp"
#include "chungs/geometry/trajectory.hpp"

namespace chungs::app {

// Throws Error naming the file when it cannot be written or fewer than 2 poses matched.
void write_ate_plot(const std::string& file, const Trajectory& gt, const Trajectory& est, const AteResult& ate);

}  // namespace chungs::app
