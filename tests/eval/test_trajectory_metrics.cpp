#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "chungs/eval/trajectory_metrics.hpp"

using namespace chungs;

namespace {

Eigen::Quaterniond random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized();
}

Eigen::Vector3d randn3(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return {n(rng), n(rng), n(rng)};
}

// A random walk of camera poses at 10 Hz: steps of ~0.5 m, turns of ~0.1 rad.
Trajectory random_walk(size_t n, std::mt19937& rng, double t0 = 100.0) {
  Trajectory t;
  SE3 pose(random_rotation(rng), randn3(rng, 5.0));
  for (size_t i = 0; i < n; ++i) {
    t.push_back(t0 + 0.1 * double(i), pose);
    Eigen::Matrix<double, 6, 1> xi;
    xi << randn3(rng, 0.5), randn3(rng, 0.1);
    pose = pose * SE3::exp(xi);
  }
  return t;
}

Sim3 random_sim3(std::mt19937& rng, double smin, double smax) {
  std::uniform_real_distribution<double> s(smin, smax);
  return Sim3(s(rng), random_rotation(rng), randn3(rng, 10.0));
}

Trajectory transformed(const Trajectory& t, const Sim3& s) {
  Trajectory out = t;
  for (auto& p : out.poses) p = s.apply(p);
  return out;
}

double rotation_deg(const SE3& e) { return Eigen::AngleAxisd(e.q).angle() * 180.0 / M_PI; }

}  // namespace

TEST(ErrorStats, MatchesHandComputedValues) {
  ErrorStats s = error_stats({4.0, 1.0, 3.0, 2.0});
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(error_stats({5.0, 1.0, 2.0}).median, 2.0);
  EXPECT_THROW(error_stats({}), Error);
}

TEST(Ate, Sim3AlignmentUndoesRandomSimilarity) {
  std::mt19937 rng(42);
  for (int trial = 0; trial < 5; ++trial) {
    Trajectory gt = random_walk(200, rng);
    Sim3 s = random_sim3(rng, 0.3, 3.0);
    AteResult r = compute_ate(gt, transformed(gt, s), {Alignment::Sim3, 0.02});
    EXPECT_EQ(r.matched(), 200u);
    EXPECT_LT(r.stats.rmse, 1e-9);
    EXPECT_LT(r.stats.max, 1e-9);
    EXPECT_NEAR(r.alignment.s, 1.0 / s.s, 1e-9);
  }
}

TEST(Ate, Se3AlignmentCannotAbsorbScale) {
  std::mt19937 rng(43);
  for (int trial = 0; trial < 5; ++trial) {
    Trajectory gt = random_walk(200, rng);
    Sim3 s = random_sim3(rng, 0.3, 3.0);
    if (std::abs(s.s - 1.0) < 0.1) s.s = 1.5;
    AteResult r = compute_ate(gt, transformed(gt, s), {Alignment::SE3, 0.02});
    EXPECT_GT(r.stats.rmse, 1e-2);
    EXPECT_DOUBLE_EQ(r.alignment.s, 1.0);
  }
}

TEST(Ate, Se3AlignmentUndoesRigidTransform) {
  std::mt19937 rng(44);
  for (int trial = 0; trial < 5; ++trial) {
    Trajectory gt = random_walk(200, rng);
    Sim3 s(1.0, random_rotation(rng), randn3(rng, 10.0));
    AteResult r = compute_ate(gt, transformed(gt, s), {Alignment::SE3, 0.02});
    EXPECT_LT(r.stats.rmse, 1e-9);
    // Without alignment the same copy is far off.
    EXPECT_GT(compute_ate(gt, transformed(gt, s), {Alignment::None, 0.02}).stats.rmse, 1e-2);
  }
}

TEST(Ate, IsotropicNoiseGivesSigmaTimesSqrt3) {
  std::mt19937 rng(45);
  const double sigma = 0.05;
  Trajectory gt = random_walk(3000, rng);
  Trajectory est = gt;
  for (auto& p : est.poses) p.t += randn3(rng, sigma);
  for (Alignment a : {Alignment::None, Alignment::SE3}) {
    AteResult r = compute_ate(gt, est, {a, 0.02});
    // RMSE of 9000 squared normals: relative spread ~0.8 %, so 4 % is five sigma.
    EXPECT_NEAR(r.stats.rmse, sigma * std::sqrt(3.0), 0.04 * sigma * std::sqrt(3.0));
    // Mean of a chi(3) variable: 2 sqrt(2 / pi) sigma.
    EXPECT_NEAR(r.stats.mean, 2.0 * std::sqrt(2.0 / M_PI) * sigma, 0.04 * sigma);
  }
}

TEST(Ate, AssociatesJitteredAndMissingStamps) {
  std::mt19937 rng(46);
  Trajectory gt = random_walk(200, rng);
  Sim3 s = random_sim3(rng, 0.3, 3.0);
  Trajectory full = transformed(gt, s), est;
  std::uniform_real_distribution<double> jitter(-0.008, 0.008);
  std::vector<size_t> source;  // gt index each estimate pose came from
  for (size_t i = 0; i < full.size(); ++i) {
    if (i % 5 == 3) continue;
    est.push_back(full.stamps[i] + jitter(rng), full.poses[i]);
    source.push_back(i);
  }
  AteResult r = compute_ate(gt, est, {Alignment::Sim3, 0.02});
  ASSERT_EQ(r.matched(), 160u);
  for (auto [i, j] : r.pairs) EXPECT_EQ(i, source[j]);
  EXPECT_LT(r.stats.rmse, 1e-9);

  AteResult tight = compute_ate(gt, est, {Alignment::Sim3, 0.004});
  EXPECT_LT(tight.matched(), 160u);
  EXPECT_GT(tight.matched(), 3u);
  for (auto [i, j] : tight.pairs) EXPECT_LE(std::abs(gt.stamps[i] - est.stamps[j]), 0.004);
}

TEST(Ate, FailsWithFewerThanThreeMatches) {
  std::mt19937 rng(47);
  Trajectory gt = random_walk(50, rng);
  Trajectory shifted = gt;
  for (double& t : shifted.stamps) t += 1000.0;
  EXPECT_THROW(compute_ate(gt, shifted), Error);
  Trajectory two;
  two.push_back(gt.stamps[0], gt.poses[0]);
  two.push_back(gt.stamps[1], gt.poses[1]);
  try {
    compute_ate(gt, two);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("only 2 poses matched"), std::string::npos) << e.what();
  }
}

TEST(Rpe, IdenticalTrajectoriesGiveZero) {
  std::mt19937 rng(48);
  Trajectory gt = random_walk(100, rng);
  for (int d : {1, 4}) {
    RpeResult r = compute_rpe(gt, gt, AteOptions{Alignment::None, 0.02}, d);
    EXPECT_EQ(r.trans.count, size_t(100 - d));
    EXPECT_LT(r.trans.rmse, 1e-12);
    EXPECT_LT(r.rot_deg.rmse, 1e-9);
  }
}

TEST(Rpe, ConstantPerStepErrorIsRecovered) {
  std::mt19937 rng(49);
  Trajectory gt = random_walk(150, rng);
  Eigen::Matrix<double, 6, 1> xi;
  xi << randn3(rng, 0.05), randn3(rng, 0.02);
  const SE3 step_err = SE3::exp(xi);
  Trajectory est;
  SE3 p(random_rotation(rng), randn3(rng, 3.0));  // the estimate may start anywhere
  for (size_t i = 0; i < gt.size(); ++i) {
    est.push_back(gt.stamps[i], p);
    if (i + 1 < gt.size()) p = p * (gt.poses[i].inverse() * gt.poses[i + 1]) * step_err;
  }
  for (Alignment a : {Alignment::None, Alignment::SE3}) {
    RpeResult r = compute_rpe(gt, est, AteOptions{a, 0.02}, 1);
    EXPECT_NEAR(r.trans.rmse, step_err.t.norm(), 1e-9);
    EXPECT_NEAR(r.trans.max - r.trans.min, 0.0, 1e-9);
    EXPECT_NEAR(r.rot_deg.rmse, rotation_deg(step_err), 1e-7);
    EXPECT_GT(r.trans.rmse, 1e-3);
  }
}

TEST(Rpe, InvariantToRigidTransformAndScaledOnlyBySim3) {
  std::mt19937 rng(50);
  Trajectory gt = random_walk(120, rng);
  Sim3 rigid(1.0, random_rotation(rng), randn3(rng, 10.0));
  for (int d : {1, 3, 7}) {
    RpeResult r = compute_rpe(gt, transformed(gt, rigid), AteOptions{Alignment::None, 0.02}, d);
    EXPECT_LT(r.trans.rmse, 1e-9);
    EXPECT_LT(r.rot_deg.rmse, 1e-7);
  }
  // A scaled copy: relative translations grow by s, so |E.t| = |s - 1| |Q_i^-1 Q_j|.t with SE3
  // alignment, and Sim3 alignment removes it.
  Sim3 scaled(2.5, random_rotation(rng), randn3(rng, 10.0));
  const int d = 2;
  RpeResult se3 = compute_rpe(gt, transformed(gt, scaled), AteOptions{Alignment::SE3, 0.02}, d);
  double sq = 0;
  for (size_t i = 0; i + d < gt.size(); ++i) {
    double e = 1.5 * (gt.poses[i].inverse() * gt.poses[i + d]).t.norm();
    sq += e * e;
  }
  EXPECT_NEAR(se3.trans.rmse, std::sqrt(sq / double(gt.size() - d)), 1e-9);
  EXPECT_LT(se3.rot_deg.rmse, 1e-7);
  RpeResult sim3 = compute_rpe(gt, transformed(gt, scaled), AteOptions{Alignment::Sim3, 0.02}, d);
  EXPECT_LT(sim3.trans.rmse, 1e-9);
}

TEST(Rpe, RejectsDeltaOutOfRange) {
  std::mt19937 rng(51);
  Trajectory gt = random_walk(10, rng);
  EXPECT_THROW(compute_rpe(gt, gt, AteOptions{}, 0), Error);
  EXPECT_THROW(compute_rpe(gt, gt, AteOptions{}, 10), Error);
  EXPECT_NO_THROW(compute_rpe(gt, gt, AteOptions{}, 9));
}

TEST(Alignment, ParsesNames) {
  EXPECT_EQ(parse_alignment("SE3"), Alignment::SE3);
  EXPECT_EQ(parse_alignment("sim3"), Alignment::Sim3);
  EXPECT_EQ(parse_alignment("none"), Alignment::None);
  EXPECT_THROW(parse_alignment("affine"), Error);
  EXPECT_STREQ(alignment_name(Alignment::Sim3), "sim3");
}
