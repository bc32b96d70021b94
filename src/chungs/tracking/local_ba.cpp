#include "chungs/tracking/local_ba.hpp"

#include <ceres/manifold.h>

#include <algorithm>
#include <array>
#include <memory>
#include <unordered_map>
#include <unordered_set>

namespace chungs::tracking {

LocalBAResult local_bundle_adjust(Map& map, long kf, const Intrinsics& k, float scale_factor, int window,
                                  int iterations) {
  LocalBAResult res;
  std::vector<long> local = {kf};
  for (auto& [id, n] : map.covisible(kf, 1, size_t(std::max(0, window - 1)))) local.push_back(id);
  std::unordered_set<long> local_set(local.begin(), local.end());
  std::unordered_set<long> pts;
  for (long id : local)
    for (long pid : map.kf(id).points)
      if (pid >= 0 && map.point(pid)) pts.insert(pid);
  std::unordered_set<long> fixed;
  for (long pid : pts)
    for (auto& [id, i] : map.point(pid)->obs)
      if (!local_set.count(id)) fixed.insert(id);
  // The first keyframe anchors the map; with no outside keyframe yet, the oldest local one does.
  if (local_set.count(0)) fixed.insert(0);
  if (fixed.empty()) fixed.insert(*std::min_element(local.begin(), local.end()));
  if (local.size() + fixed.size() < 2) return res;

  std::unordered_map<long, std::array<double, 7>> poses;  // qx qy qz qw tx ty tz of T_cw
  std::unordered_map<long, std::array<double, 3>> xyz;
  ceres::Problem::Options popt;
  popt.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(popt);
  ceres::EigenQuaternionManifold qman;
  auto pose_block = [&](long id) -> std::array<double, 7>& {
    auto it = poses.find(id);
    if (it != poses.end()) return it->second;
    SE3 T = map.kf(id).T_cw();
    auto& a = poses[id];
    a = {T.q.x(), T.q.y(), T.q.z(), T.q.w(), T.t.x(), T.t.y(), T.t.z()};
    problem.AddParameterBlock(a.data(), 4, &qman);
    problem.AddParameterBlock(a.data() + 4, 3);
    if (fixed.count(id) || !local_set.count(id)) {
      problem.SetParameterBlockConstant(a.data());
      problem.SetParameterBlockConstant(a.data() + 4);
    }
    return a;
  };
  struct Obs {
    long pid, kf;
    int kp;
  };
  std::vector<Obs> all;
  for (long pid : pts) {
    MapPoint* p = map.point(pid);
    auto& X = xyz[pid];
    X = {p->pos.x(), p->pos.y(), p->pos.z()};
    for (auto& [id, i] : p->obs) {
      auto& P = pose_block(id);
      const Keyframe& K = map.kf(id);
      const auto& kp = K.feat.kps[i];
      double ur = K.feat.u_right[i];
      double delta = std::sqrt(has_right(ur) ? kChi2Stereo : kChi2Mono);
      problem.AddResidualBlock(
          ReprojectionCost::create(k, kp.pt.x, kp.pt.y, ur, 1.0 / level_scale(kp.octave, scale_factor)),
          new ceres::HuberLoss(delta), P.data(), P.data() + 4, X.data());
      all.push_back({pid, id, i});
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;  // a few keyframes: the reduced camera system is small
  // Points first, then poses: the elimination order DENSE_SCHUR would find, given rather than searched for
  // (a quarter of the solver's preprocessing on KITTI's windows).
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (auto& [pid, X] : xyz) ordering->AddElementToGroup(X.data(), 0);
  for (auto& [id, a] : poses) ordering->AddElementToGroup(a.data(), 1), ordering->AddElementToGroup(a.data() + 4, 1);
  so.linear_solver_ordering = ordering;
  so.max_num_iterations = iterations;
  so.num_threads = 2;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);

  for (long id : local) {
    if (fixed.count(id)) continue;
    auto& a = poses.at(id);
    SE3 T_cw(Eigen::Quaterniond(a[3], a[0], a[1], a[2]).normalized(), Eigen::Vector3d(a[4], a[5], a[6]));
    map.kf(id).T_wc = T_cw.inverse();
    res.keyframes.push_back(id);
  }
  for (auto& [pid, X] : xyz) map.point(pid)->pos = Eigen::Vector3d(X[0], X[1], X[2]);
  res.points = int(xyz.size());
  // Observations that still disagree with the optimised geometry are dropped (the point may go with them).
  for (const Obs& o : all) {
    MapPoint* p = map.point(o.pid);
    if (!p || !p->obs.count(o.kf)) continue;
    const Keyframe& K = map.kf(o.kf);
    SE3 T = K.T_cw();
    const auto& kp = K.feat.kps[o.kp];
    double ur = K.feat.u_right[o.kp];
    double chi2 = reprojection_chi2(k, T.q, T.t, p->pos, kp.pt.x, kp.pt.y, ur, 1.0 / level_scale(kp.octave, scale_factor));
    if (chi2 > (has_right(ur) ? kChi2Stereo : kChi2Mono)) {
      map.erase_observation(o.pid, o.kf);
      ++res.outliers;
    }
  }
  return res;
}

}  // namespace chungs::tracking
