// Trajectory accuracy the way evo reports it: absolute trajectory error (ATE) of positions after
// aligning the estimate to the ground truth, and relative pose error (RPE) over a frame delta.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/geometry/trajectory.hpp"

namespace chungs {

// How the estimate is brought into the ground-truth frame before errors are taken: not at all,
// rigidly (stereo / RGB-D), or rigidly with scale (monocular), by Umeyama on the matched positions.
enum class Alignment { None, SE3, Sim3 };
Alignment parse_alignment(const std::string& name);  // "none" | "se3" | "sim3" (case-insensitive)
const char* alignment_name(Alignment a);

struct ErrorStats {
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;  // std: population (as numpy)
  size_t count = 0;
};
// Throws Error on an empty list.
ErrorStats error_stats(std::vector<double> errors);

struct AteOptions {
  Alignment align = Alignment::SE3;
  double max_dt = 0.02;  // seconds between matched stamps
};

struct AteResult {
  Alignment align = Alignment::SE3;
  Sim3 alignment;  // maps estimate coordinates into the ground-truth frame (identity for None)
  std::vector<std::pair<size_t, size_t>> pairs;  // (ground-truth index, estimate index), in time order
  std::vector<double> errors;                    // |p_gt - alignment * p_est| per pair, metres
  ErrorStats stats;
  size_t matched() const { return pairs.size(); }
};

// Associates stamps (each pose used once, nearest within max_dt), aligns, and measures position
// errors. Throws Error when fewer than 3 pairs match (naming both trajectories' sizes and spans).
AteResult compute_ate(const Trajectory& gt, const Trajectory& est, const AteOptions& opt = {});

struct RpeResult {
  int delta = 1;        // in matched frames
  ErrorStats trans;     // |translation of E|, metres
  ErrorStats rot_deg;   // rotation angle of E, degrees
};

// Over the matched pairs of `ate` (and with its alignment applied to the estimate, which only
// matters for the scale of Sim3), for each i: E = (Q_i^-1 Q_{i+d})^-1 (P_i^-1 P_{i+d}), Q ground
// truth, P estimate. Throws Error unless 1 <= delta < matched pairs.
RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est, const AteResult& ate, int delta = 1);
// Associates and aligns as compute_ate does, then computes the RPE.
RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est, const AteOptions& opt, int delta = 1);

}  // namespace chungs
