// `eval ate` on a monocular trajectory (issue 25): the file says it comes from one camera (track
// --input mono writes that line), and the default alignment is then Sim(3), said in the output.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "chungs/geometry/trajectory.hpp"
#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;
namespace fs = std::filesystem;

namespace {

// A curving path and the same path as a monocular tracker would give it: another unit (x 0.37), turned
// and moved (the tracker's own frame).
struct Pair {
  chungs::Trajectory gt, est;
};
Pair make_pair() {
  Pair p;
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 1, 0.1).normalized()));
  const Eigen::Vector3d move(3, -1, 2);
  for (int i = 0; i < 60; ++i) {
    const double a = 0.08 * i;
    const Eigen::Quaterniond q(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()));
    const Eigen::Vector3d t(10 * std::sin(a), 0.3 * std::sin(3 * a), 10 * (1 - std::cos(a)) + 0.5 * i);
    p.gt.push_back(0.1 * i, chungs::SE3(q, t));
    p.est.push_back(0.1 * i, chungs::SE3(turn * q, 0.37 * (turn * t) + move));
  }
  return p;
}

std::string ate_args(const fs::path& gt, const fs::path& est) {
  return "eval ate --gt " + gt.string() + " --est " + est.string();
}

}  // namespace

TEST(CliMonoAte, MonocularFileIsAlignedWithSim3ByItselfAndSaysSo) {
  chungs::test::TempDir dir;
  const Pair p = make_pair();
  chungs::write_tum_trajectory(dir / "gt.txt", p.gt);
  chungs::write_tum_trajectory(dir / "mono.txt", p.est, true);
  chungs::write_tum_trajectory(dir / "plain.txt", p.est);
  EXPECT_TRUE(chungs::trajectory_is_monocular(dir / "mono.txt"));
  EXPECT_FALSE(chungs::trajectory_is_monocular(dir / "plain.txt"));

  auto r = run_cli(ate_args(dir / "gt.txt", dir / "mono.txt"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("says it comes from a monocular run"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ATE (sim3 alignment"), std::string::npos) << r.out;
  r = run_cli(ate_args(dir / "gt.txt", dir / "mono.txt") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ate"]["alignment"], "sim3");
  EXPECT_EQ(j["estimate_monocular"], true);
  EXPECT_EQ(j["alignment_chosen_by"], "auto");
  EXPECT_LT(j["ate"]["rmse"].get<double>(), 1e-6);
  EXPECT_NEAR(j["ate"]["transform"]["scale"].get<double>(), 1 / 0.37, 1e-6) << j["ate"]["transform"].dump();

  // The same poses without the line: rigid alignment, as before, and no word about monocular.
  r = run_cli(ate_args(dir / "gt.txt", dir / "plain.txt") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ate"]["alignment"], "se3");
  EXPECT_EQ(j["estimate_monocular"], false);
  EXPECT_GT(j["ate"]["rmse"].get<double>(), 1.0);
  r = run_cli(ate_args(dir / "gt.txt", dir / "plain.txt"));
  EXPECT_EQ(r.out.find("monocular"), std::string::npos) << r.out;

  // --align given wins; se3 on a monocular file says what it measures.
  r = run_cli(ate_args(dir / "gt.txt", dir / "mono.txt") + " --align se3");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("ATE (se3 alignment"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("comes from a monocular run, whose scale is the tracker's own"), std::string::npos) << r.out;
  r = run_cli(ate_args(dir / "gt.txt", dir / "mono.txt") + " --align affine");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--align must be auto, se3, sim3 or none, got affine"), std::string::npos) << r.out;
}

TEST(CliMonoAte, KittiFormatCarriesTheLineToo) {
  chungs::test::TempDir dir;
  const Pair p = make_pair();
  chungs::write_kitti_trajectory(dir / "gt.txt", p.gt);
  chungs::write_kitti_trajectory(dir / "mono.txt", p.est, true);
  // Both readers skip the line: the poses read back are the ones written.
  const chungs::Trajectory back = chungs::read_trajectory(dir / "mono.txt");
  ASSERT_EQ(back.size(), p.est.size());
  EXPECT_LT((back.poses[7].t - p.est.poses[7].t).norm(), 1e-9);
  auto r = run_cli(ate_args(dir / "gt.txt", dir / "mono.txt") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ate"]["alignment"], "sim3");
  EXPECT_LT(j["ate"]["rmse"].get<double>(), 1e-6);
}

TEST(CliMonoAte, TrackInputMonoWritesTheLineAndStereoDoesNot) {
  chungs::test::TempDir dir;
  const std::string street = "synth-street:length=30,width=320,height=96,seed=1";
  auto r = run_cli("-q track --dataset " + street + " --input mono --max-frames 12 --out " +
                   (dir / "mono.txt").string());
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream f(dir / "mono.txt");
  std::string first;
  std::getline(f, first);
  EXPECT_EQ(first, chungs::kMonocularTrajectoryComment);
  r = run_cli("-q track --dataset " + street + " --max-frames 4 --out " + (dir / "stereo.txt").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(chungs::trajectory_is_monocular(dir / "stereo.txt"));
}
