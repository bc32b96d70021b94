// SE3 pose-graph optimisation (Ceres): keyframe poses constrained by measured relative poses (odometry,
// covisibility and loop edges); used to spread a loop-closure correction along the loop.
#pragma once
#include <unordered_map>
#include <vector>

#include "chungs/geometry/se3.hpp"

namespace chungs::tracking {

struct PoseGraphEdge {
  long i, j;
  SE3 T_ij;  // measured T_wi^-1 * T_wj
  double weight = 1.0;
};

// Optimises `poses` (camera-to-world, by keyframe id) in place; keyframes in `fixed` do not move.
// Returns the final cost. Throws Error when an edge names a pose that is not in `poses`.
double optimize_pose_graph(std::unordered_map<long, SE3>& poses, const std::vector<PoseGraphEdge>& edges,
                           const std::vector<long>& fixed, int iterations = 30);

}  // namespace chungs::tracking
