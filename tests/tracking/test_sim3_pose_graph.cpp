// Sim(3) pose graph (issue 25): a monocular loop whose scale shrank along the way is closed with its scale
// drift spread over the loop, which the SE3 graph cannot do.
#include <gtest/gtest.h>

#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/tracking/pose_graph.hpp"
#include "chungs/tracking/sim3_pose_graph.hpp"

namespace chungs::tracking {
namespace {

constexpr int kN = 40;

// Keyframes on a circle of radius 20 m, looking along it.
SE3 truth(int i) {
  const double a = 2 * M_PI * i / kN;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitY()));
  return SE3(q, Eigen::Vector3d(20 * std::sin(a), 0, 20 * std::cos(a)));
}

struct Drifted {
  std::vector<SE3> est;     // the drifted estimate: every step shorter by 2 %
  std::vector<double> unit; // true metres per estimated metre near keyframe i
};

Drifted drift() {
  Drifted d;
  d.est.push_back(truth(0));
  d.unit.push_back(1);
  for (int i = 1; i < kN; ++i) {
    const SE3 rel = truth(i - 1).inverse() * truth(i);
    const double shrink = std::pow(0.98, i);
    d.est.push_back(d.est.back() * SE3(rel.q, rel.t * shrink));
    d.unit.push_back(1 / shrink);
  }
  return d;
}

double position_rmse(const std::vector<Eigen::Vector3d>& p) {
  double sum = 0;
  for (int i = 0; i < kN; ++i) sum += (p[size_t(i)] - truth(i).t).squaredNorm();
  return std::sqrt(sum / kN);
}

TEST(Sim3PoseGraph, LoopClosureSpreadsScaleDrift) {
  const Drifted d = drift();
  std::unordered_map<long, Sim3> sim;
  std::unordered_map<long, SE3> rigid;
  std::vector<Sim3Edge> sim_edges;
  std::vector<PoseGraphEdge> se3_edges;
  for (int i = 0; i < kN; ++i) sim[i] = Sim3(d.est[size_t(i)]), rigid[i] = d.est[size_t(i)];
  for (int i = 1; i < kN; ++i) {
    const SE3 rel = d.est[size_t(i - 1)].inverse() * d.est[size_t(i)];
    sim_edges.push_back({i - 1, i, Sim3(rel)});
    se3_edges.push_back({i - 1, i, rel});
  }
  // The loop: keyframe kN-1 recognises keyframe 0 and measures where it truly is, and that its own map is
  // unit[kN-1] times too small (its similarity to the world scales by that).
  const SE3 loop_rel = truth(0).inverse() * truth(kN - 1);
  const double drift_before = position_rmse([&] {
    std::vector<Eigen::Vector3d> p;
    for (int i = 0; i < kN; ++i) p.push_back(d.est[size_t(i)].t);
    return p;
  }());
  sim_edges.push_back({0, kN - 1, Sim3(d.unit[kN - 1], loop_rel.q, loop_rel.t)});
  se3_edges.push_back({0, kN - 1, loop_rel});
  optimize_sim3_pose_graph(sim, sim_edges, {0}, 50);
  optimize_pose_graph(rigid, se3_edges, {0}, 50);
  std::vector<Eigen::Vector3d> ps, pr;
  for (int i = 0; i < kN; ++i) ps.push_back(sim.at(i).t), pr.push_back(rigid.at(i).t);
  const double e_sim = position_rmse(ps), e_rigid = position_rmse(pr);
  EXPECT_LT(e_sim, 0.25 * e_rigid) << "Sim(3) " << e_sim << " m, SE3 " << e_rigid << " m, before " << drift_before << " m";
  EXPECT_LT(e_sim, 0.1 * drift_before);
  // The recovered scales undo the drift: keyframe i's scale is about unit[i].
  EXPECT_NEAR(sim.at(kN - 1).s, d.unit[kN - 1], 0.05 * d.unit[kN - 1]);
  EXPECT_NEAR(sim.at(kN / 2).s, d.unit[kN / 2], 0.15 * d.unit[kN / 2]);
}

TEST(Sim3PoseGraph, RefusesBadEdges) {
  std::unordered_map<long, Sim3> poses = {{0, Sim3()}, {1, Sim3()}};
  EXPECT_THROW(optimize_sim3_pose_graph(poses, {{0, 2, Sim3()}}, {0}), Error);
  EXPECT_THROW(optimize_sim3_pose_graph(poses, {{1, 1, Sim3()}}, {0}), Error);
  EXPECT_THROW(optimize_sim3_pose_graph(poses, {{0, 1, Sim3(0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero())}}, {0}), Error);
}

}  // namespace
}  // namespace chungs::tracking
