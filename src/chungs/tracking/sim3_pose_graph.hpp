// Sim(3) pose-graph optimisation (Ceres) for monocular maps (issue 25): every keyframe has a scale as well as
// a pose, so a loop closure can spread the scale drift accumulated along the loop, which an SE3 graph
// (pose_graph.hpp) cannot: with one camera the map's unit shrinks or grows as it goes.
#pragma once
#include <unordered_map>
#include <vector>

#include "chungs/geometry/se3.hpp"

namespace chungs::tracking {

struct Sim3Edge {
  long i, j;
  Sim3 S_ij;  // measured S_wi^-1 * S_wj
  double weight = 1.0;
};

// Optimises `poses` (camera-to-world similarities, by keyframe id) in place; keyframes in `fixed` do not move.
// Returns the final cost. Throws Error when an edge names a pose that is not in `poses` or joins one to itself.
double optimize_sim3_pose_graph(std::unordered_map<long, Sim3>& poses, const std::vector<Sim3Edge>& edges,
                                const std::vector<long>& fixed, int iterations = 30);

}  // namespace chungs::tracking
