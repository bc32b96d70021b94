#include "chungs/tracking/reprojection.hpp"

namespace chungs::tracking {
namespace {

struct PoseOnlyCost {
  ReprojectionCost c;
  Eigen::Vector3d X;
  template <typename T>
  bool operator()(const T* q, const T* t, T* r) const {
    const T Xt[3] = {T(X.x()), T(X.y()), T(X.z())};
    return c(q, t, Xt, r);
  }
};

// Bundle adjustment gives every observation three residual rows (a zero row without a right column):
// with one residual size Ceres eliminates the points with its fixed-size Schur code instead of the
// dynamic one, which had been most of the local BA's time.
struct PaddedCost {
  ReprojectionCost c;
  template <typename T>
  bool operator()(const T* q, const T* t, const T* X, T* r) const {
    r[2] = T(0);
    return c(q, t, X, r);
  }
};

}  // namespace

ceres::CostFunction* ReprojectionCost::create(const Intrinsics& k, double u, double v, double ur, double inv_sigma) {
  if (has_right(ur))
    return new ceres::AutoDiffCostFunction<ReprojectionCost, 3, 4, 3, 3>(new ReprojectionCost(k, u, v, ur, inv_sigma));
  return new ceres::AutoDiffCostFunction<PaddedCost, 3, 4, 3, 3>(new PaddedCost{ReprojectionCost(k, u, v, ur, inv_sigma)});
}

ceres::CostFunction* ReprojectionCost::create_pose_only(const Intrinsics& k, double u, double v, double ur,
                                                        double inv_sigma, const Eigen::Vector3d& X) {
  auto* f = new PoseOnlyCost{ReprojectionCost(k, u, v, ur, inv_sigma), X};
  if (has_right(ur)) return new ceres::AutoDiffCostFunction<PoseOnlyCost, 3, 4, 3>(f);
  return new ceres::AutoDiffCostFunction<PoseOnlyCost, 2, 4, 3>(f);
}

double reprojection_chi2(const Intrinsics& k, const Eigen::Quaterniond& q_cw, const Eigen::Vector3d& t_cw,
                         const Eigen::Vector3d& X, double u, double v, double ur, double inv_sigma) {
  Eigen::Vector3d p = q_cw * X + t_cw;
  if (p.z() <= 1e-3) return 1e12;
  double pu = k.fx * p.x() / p.z() + k.cx, pv = k.fy * p.y() / p.z() + k.cy;
  double e = (pu - u) * (pu - u) + (pv - v) * (pv - v);
  if (has_right(ur)) {
    double pr = pu - k.bf / p.z();
    e += (pr - ur) * (pr - ur);
  }
  return e * inv_sigma * inv_sigma;
}

}  // namespace chungs::tracking
