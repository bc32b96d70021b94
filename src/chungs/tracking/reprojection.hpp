// Reprojection residuals shared by pose-only optimisation and bundle adjustment. The camera pose is
// world-to-camera as an Eigen quaternion (x, y, z, w) and a translation; stereo/RGB-D observations add the
// right-image column u_r = u - bf / z, so depth uncertainty grows with distance as it should.
#pragma once
#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "chungs/tracking/features.hpp"

namespace chungs::tracking {

struct Intrinsics {
  double fx, fy, cx, cy, bf;
};

struct ReprojectionCost {
  ReprojectionCost(const Intrinsics& k, double u, double v, double ur, double inv_sigma)
      : k_(k), u_(u), v_(v), ur_(ur), w_(inv_sigma) {}

  template <typename T>
  bool operator()(const T* q_cw, const T* t_cw, const T* X, T* r) const {
    Eigen::Map<const Eigen::Quaternion<T>> q(q_cw);
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(t_cw), Xw(X);
    Eigen::Matrix<T, 3, 1> p = q * Xw + t;
    // Points behind the camera get a large residual instead of a division blow-up.
    T z = p.z() < T(1e-3) ? T(1e-3) : p.z();
    T iz = T(1) / z;
    T u = T(k_.fx) * p.x() * iz + T(k_.cx);
    r[0] = (u - T(u_)) * T(w_);
    r[1] = (T(k_.fy) * p.y() * iz + T(k_.cy) - T(v_)) * T(w_);
    if (has_right(ur_)) r[2] = (u - T(k_.bf) * iz - T(ur_)) * T(w_);
    return true;
  }

  // Point free (bundle adjustment): residual size 3 (the third row 0 without a right column). Point fixed
  // (pose-only): size 3 with a right column, else 2.
  static ceres::CostFunction* create(const Intrinsics& k, double u, double v, double ur, double inv_sigma);
  static ceres::CostFunction* create_pose_only(const Intrinsics& k, double u, double v, double ur, double inv_sigma,
                                               const Eigen::Vector3d& X);

  Intrinsics k_;
  double u_, v_, ur_, w_;
};

// Squared, weighted error of an observation (chi-square with 2 or 3 degrees of freedom).
double reprojection_chi2(const Intrinsics& k, const Eigen::Quaterniond& q_cw, const Eigen::Vector3d& t_cw,
                         const Eigen::Vector3d& X, double u, double v, double ur, double inv_sigma);

constexpr double kChi2Mono = 5.991, kChi2Stereo = 7.815;  // 95 % with 2 / 3 degrees of freedom

}  // namespace chungs::tracking
