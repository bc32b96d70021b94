#include "chungs/tracking/pose_graph.hpp"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <array>

#include "chungs/common/error.hpp"

namespace chungs::tracking {
namespace {

// Residual of the relative pose: translation and twice the vector part of the error quaternion.
struct RelativePoseCost {
  RelativePoseCost(const SE3& T_ij, double w) : q_(T_ij.q.conjugate()), t_(-(T_ij.q.conjugate() * T_ij.t)), w_(w) {}
  template <typename T>
  bool operator()(const T* qi_, const T* ti_, const T* qj_, const T* tj_, T* r) const {
    Eigen::Map<const Eigen::Quaternion<T>> qi(qi_), qj(qj_);
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> ti(ti_), tj(tj_);
    Eigen::Quaternion<T> qi_inv = qi.conjugate();
    Eigen::Quaternion<T> q_ij = qi_inv * qj;                   // estimate of T_ij
    Eigen::Matrix<T, 3, 1> t_ij = qi_inv * (tj - ti);
    Eigen::Quaternion<T> qm = q_.cast<T>();                    // measured inverse
    Eigen::Quaternion<T> q_e = qm * q_ij;
    Eigen::Matrix<T, 3, 1> t_e = qm * t_ij + t_.cast<T>();
    if (q_e.w() < T(0)) q_e.coeffs() = -q_e.coeffs();
    for (int k = 0; k < 3; ++k) r[k] = t_e[k] * T(w_), r[3 + k] = T(2) * q_e.vec()[k] * T(w_);
    return true;
  }
  Eigen::Quaterniond q_;
  Eigen::Vector3d t_;
  double w_;
};

}  // namespace

double optimize_pose_graph(std::unordered_map<long, SE3>& poses, const std::vector<PoseGraphEdge>& edges,
                           const std::vector<long>& fixed, int iterations) {
  std::unordered_map<long, std::array<double, 7>> p;
  for (auto& [id, T] : poses) p[id] = {T.q.x(), T.q.y(), T.q.z(), T.q.w(), T.t.x(), T.t.y(), T.t.z()};
  ceres::Problem::Options popt;
  popt.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(popt);
  ceres::EigenQuaternionManifold qman;
  for (auto& [id, a] : p) {
    problem.AddParameterBlock(a.data(), 4, &qman);
    problem.AddParameterBlock(a.data() + 4, 3);
  }
  for (const auto& e : edges) {
    auto a = p.find(e.i), b = p.find(e.j);
    if (a == p.end() || b == p.end()) fail("pose graph: edge ", e.i, " - ", e.j, " names a keyframe without a pose");
    // Ceres aborts the process on a residual that names one block twice.
    if (e.i == e.j) fail("pose graph: edge ", e.i, " - ", e.j, " joins a keyframe to itself");
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(
                                 new RelativePoseCost(e.T_ij, e.weight)),
                             nullptr, a->second.data(), a->second.data() + 4, b->second.data(), b->second.data() + 4);
  }
  for (long id : fixed) {
    auto it = p.find(id);
    if (it == p.end()) continue;
    problem.SetParameterBlockConstant(it->second.data());
    problem.SetParameterBlockConstant(it->second.data() + 4);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = iterations;
  so.num_threads = 2;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  for (auto& [id, a] : p)
    poses[id] = SE3(Eigen::Quaterniond(a[3], a[0], a[1], a[2]).normalized(), Eigen::Vector3d(a[4], a[5], a[6]));
  return summary.final_cost;
}

}  // namespace chungs::tracking
