#include "chungs/tracking/sim3_pose_graph.hpp"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <array>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs::tracking {
namespace {

// Residual of a relative similarity: translation, twice the vector part of the error rotation, and the log of
// the error scale. The scale is stored as its log so that it stays positive and is optimised multiplicatively.
struct RelativeSim3Cost {
  RelativeSim3Cost(const Sim3& S_ij, double w) : m_(S_ij), w_(w) {}
  template <typename T>
  bool operator()(const T* qi_, const T* ti_, const T* li_, const T* qj_, const T* tj_, const T* lj_, T* r) const {
    Eigen::Map<const Eigen::Quaternion<T>> qi(qi_), qj(qj_);
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> ti(ti_), tj(tj_);
    const T si = exp(li_[0]), sj = exp(lj_[0]);
    // Estimate of S_ij = S_wi^-1 S_wj.
    const Eigen::Quaternion<T> qi_inv = qi.conjugate();
    const Eigen::Quaternion<T> q_ij = qi_inv * qj;
    const Eigen::Matrix<T, 3, 1> t_ij = (qi_inv * (tj - ti)) / si;
    const T s_ij = sj / si;
    // Error M^-1 S_ij, M the measurement.
    const Eigen::Quaternion<T> qm_inv = m_.q.conjugate().cast<T>();
    Eigen::Quaternion<T> q_e = qm_inv * q_ij;
    const Eigen::Matrix<T, 3, 1> t_e = (qm_inv * (t_ij - m_.t.cast<T>())) / T(m_.s);
    if (q_e.w() < T(0)) q_e.coeffs() = -q_e.coeffs();
    for (int k = 0; k < 3; ++k) r[k] = t_e[k] * T(w_), r[3 + k] = T(2) * q_e.vec()[k] * T(w_);
    r[6] = log(s_ij / T(m_.s)) * T(w_);
    return true;
  }
  Sim3 m_;
  double w_;
};

}  // namespace

double optimize_sim3_pose_graph(std::unordered_map<long, Sim3>& poses, const std::vector<Sim3Edge>& edges,
                                const std::vector<long>& fixed, int iterations) {
  std::unordered_map<long, std::array<double, 8>> p;  // qx qy qz qw tx ty tz log(s)
  for (auto& [id, S] : poses) {
    if (!(S.s > 0)) fail("Sim(3) pose graph: keyframe ", id, " has scale ", S.s);
    p[id] = {S.q.x(), S.q.y(), S.q.z(), S.q.w(), S.t.x(), S.t.y(), S.t.z(), std::log(S.s)};
  }
  ceres::Problem::Options popt;
  popt.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(popt);
  ceres::EigenQuaternionManifold qman;
  for (auto& [id, a] : p) {
    problem.AddParameterBlock(a.data(), 4, &qman);
    problem.AddParameterBlock(a.data() + 4, 3);
    problem.AddParameterBlock(a.data() + 7, 1);
  }
  for (const auto& e : edges) {
    auto a = p.find(e.i), b = p.find(e.j);
    if (a == p.end() || b == p.end()) fail("Sim(3) pose graph: edge ", e.i, " - ", e.j, " names a keyframe without a pose");
    if (e.i == e.j) fail("Sim(3) pose graph: edge ", e.i, " - ", e.j, " joins a keyframe to itself");
    if (!(e.S_ij.s > 0)) fail("Sim(3) pose graph: edge ", e.i, " - ", e.j, " has scale ", e.S_ij.s);
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativeSim3Cost, 7, 4, 3, 1, 4, 3, 1>(
                                 new RelativeSim3Cost(e.S_ij, e.weight)),
                             nullptr, a->second.data(), a->second.data() + 4, a->second.data() + 7, b->second.data(),
                             b->second.data() + 4, b->second.data() + 7);
  }
  for (long id : fixed) {
    auto it = p.find(id);
    if (it == p.end()) continue;
    for (int off : {0, 4, 7}) problem.SetParameterBlockConstant(it->second.data() + off);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = iterations;
  so.num_threads = 2;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  for (auto& [id, a] : p)
    poses[id] = Sim3(std::exp(a[7]), Eigen::Quaterniond(a[3], a[0], a[1], a[2]).normalized(), Eigen::Vector3d(a[4], a[5], a[6]));
  return summary.final_cost;
}

}  // namespace chungs::tracking
