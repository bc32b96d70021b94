// Local bundle adjustment: the newest keyframe and its covisible neighbours, with every point they see, are
// optimised together (Ceres, Huber loss); keyframes outside the window that see those points hold the gauge.
#pragma once
#include <vector>

#include "chungs/tracking/map.hpp"
#include "chungs/tracking/reprojection.hpp"

namespace chungs::tracking {

struct LocalBAResult {
  std::vector<long> keyframes;  // keyframes whose poses were optimised (and changed)
  int points = 0;               // points optimised
  int outliers = 0;             // observations removed afterwards
};

LocalBAResult local_bundle_adjust(Map& map, long kf, const Intrinsics& k, float scale_factor, int window,
                                  int iterations);

}  // namespace chungs::tracking
