#include "chungs/tracking/pose_optimizer.hpp"

#include <ceres/manifold.h>

namespace chungs::tracking {

int optimize_pose(SE3& T_cw, const Intrinsics& k, const std::vector<PoseObservation>& obs, std::vector<char>& inlier,
                  int rounds) {
  inlier.assign(obs.size(), 1);
  if (obs.size() < 3) return 0;
  Eigen::Quaterniond q = T_cw.q.normalized();
  Eigen::Vector3d t = T_cw.t;
  int n_in = int(obs.size());
  for (int round = 0; round < rounds; ++round) {
    double qa[4] = {q.x(), q.y(), q.z(), q.w()}, ta[3] = {t.x(), t.y(), t.z()};
    ceres::Problem::Options popt;
    popt.manifold_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(popt);
    problem.AddParameterBlock(qa, 4, new ceres::EigenQuaternionManifold);
    problem.AddParameterBlock(ta, 3);
    int used = 0;
    for (size_t i = 0; i < obs.size(); ++i) {
      if (!inlier[i]) continue;
      const auto& o = obs[i];
      double delta = std::sqrt(has_right(o.ur) ? kChi2Stereo : kChi2Mono);
      problem.AddResidualBlock(ReprojectionCost::create_pose_only(k, o.u, o.v, o.ur, o.inv_sigma, o.X),
                               round < rounds - 1 ? new ceres::HuberLoss(delta) : nullptr, qa, ta);
      ++used;
    }
    if (used < 3) break;
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 10;
    so.num_threads = 1;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    q = Eigen::Quaterniond(qa[3], qa[0], qa[1], qa[2]).normalized();
    t = Eigen::Vector3d(ta[0], ta[1], ta[2]);
    // Classify every observation again: an early outlier may fit the refined pose.
    n_in = 0;
    for (size_t i = 0; i < obs.size(); ++i) {
      const auto& o = obs[i];
      double chi2 = reprojection_chi2(k, q, t, o.X, o.u, o.v, o.ur, o.inv_sigma);
      inlier[i] = chi2 <= (has_right(o.ur) ? kChi2Stereo : kChi2Mono);
      n_in += inlier[i];
    }
    if (n_in < 10) break;
  }
  T_cw = SE3(q, t);
  return n_in;
}

}  // namespace chungs::tracking
