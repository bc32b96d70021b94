// Pose-only optimisation of one frame against fixed 3D points (Ceres, Huber loss), in rounds that set
// observations with a large error aside as outliers and re-solve without them.
#pragma once
#include <vector>

#include "chungs/geometry/se3.hpp"
#include "chungs/tracking/reprojection.hpp"

namespace chungs::tracking {

struct PoseObservation {
  Eigen::Vector3d X;    // world
  double u, v, ur;      // pixels; kNoRight without a right column
  double inv_sigma;     // 1 / (pyramid scale of the keypoint)
};

// Refines T_cw in place; `inlier` gets one flag per observation. Returns the number of inliers.
int optimize_pose(SE3& T_cw, const Intrinsics& k, const std::vector<PoseObservation>& obs, std::vector<char>& inlier,
                  int rounds = 4);

}  // namespace chungs::tracking
