// Least-squares alignment of corresponding point sets (Umeyama 1991): dst ~ s R src + t.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "chungs/geometry/se3.hpp"

namespace chungs {

// with_scale = false gives the SE3 solution (s = 1). Throws Error with fewer than 3 pairs, unequal
// sizes, a set all at one place, or sets that do not vary together. Collinear points (a straight
// drive) are aligned: the rotation about their line is free and changes no aligned point.
Sim3 umeyama_align(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                   bool with_scale);

}  // namespace chungs
