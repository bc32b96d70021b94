#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/geometry/trajectory.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
Trajectory random_walk(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, 1);
  Trajectory t;
  SE3 p;
  for (int i = 0; i < n; ++i) {
    Eigen::Matrix<double, 6, 1> xi;
    for (int k = 0; k < 6; ++k) xi(k) = g(rng) * (k < 3 ? 0.5 : 0.05);
    p = p * SE3::exp(xi);
    t.push_back(100.0 + 0.1 * i, p);
  }
  return t;
}
}  // namespace

TEST(Trajectory, TumAndKittiRoundTrip) {
  test::TempDir dir;
  Trajectory t = random_walk(50, 7);
  write_tum_trajectory(dir / "a.txt", t);
  write_kitti_trajectory(dir / "b.txt", t);
  Trajectory a = read_trajectory(dir / "a.txt");
  Trajectory b = read_trajectory(dir / "b.txt", 10.0);
  ASSERT_EQ(a.size(), t.size());
  ASSERT_EQ(b.size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(a.stamps[i], t.stamps[i], 1e-6);
    EXPECT_LT((a.poses[i].matrix() - t.poses[i].matrix()).norm(), 1e-9);
    EXPECT_LT((b.poses[i].matrix() - t.poses[i].matrix()).norm(), 1e-9);
    EXPECT_NEAR(b.stamps[i], 0.1 * i, 1e-12);
  }
  EXPECT_NEAR(a.path_length(), t.path_length(), 1e-6);
}

TEST(Trajectory, ErrorsNameFileAndLine) {
  test::TempDir dir;
  std::ofstream(dir / "bad.txt") << "# header\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 x 1\n";
  try {
    read_tum_trajectory(dir / "bad.txt");
    FAIL();
  } catch (const Error& e) {
    std::string m = e.what();
    EXPECT_NE(m.find("bad.txt:3"), std::string::npos) << m;
  }
  std::ofstream(dir / "short.txt") << "1 0 0 0 0 0 0 1\n2 0 0 0 0 1\n";
  EXPECT_THROW(read_tum_trajectory(dir / "short.txt"), Error);
  EXPECT_THROW(read_trajectory(dir / "missing.txt"), Error);
}

TEST(Trajectory, AssociationPairsNearestStampsOnce) {
  std::vector<double> a{0.0, 0.1, 0.2, 0.3, 0.4}, b{0.005, 0.095, 0.21, 0.5, 0.101};
  auto pairs = associate_stamps(a, b, 0.02);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0], std::make_pair(size_t(0), size_t(0)));
  EXPECT_EQ(pairs[1], std::make_pair(size_t(1), size_t(4)));  // 0.101 closer than 0.095
  EXPECT_EQ(pairs[2], std::make_pair(size_t(2), size_t(2)));
}

// A trajectory written into a map folder on a full or failing disk said only "write failed".
TEST(Trajectory, AFailedWriteNamesTheFileAndTheSystemsReason) {
  test::TempDir dir;
  const auto file = dir / "trajectory.txt";
  std::filesystem::create_symlink("/dev/full", file);
  try {
    write_tum_trajectory(file, random_walk(2000, 3));
    FAIL() << "a write to a full disk went unnoticed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("trajectory.txt: write failed (No space left on device)"), std::string::npos)
        << e.what();
  }
  std::filesystem::create_directory(dir / "taken");
  try {
    write_kitti_trajectory(dir / "taken", random_walk(2, 3));
    FAIL() << "wrote over a folder";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("taken: is a folder, not a file for the trajectory"), std::string::npos) << e.what();
  }
}
