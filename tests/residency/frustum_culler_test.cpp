#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <random>
#include <set>

#include "chungs/residency/frustum_culler.hpp"

using namespace chungs;

namespace {

// A sparse city-like map: chunks on a 120 x 120 x 5 grid (1.2 km square at 10 m), about a third present.
std::vector<ChunkId> random_map(std::mt19937& rng, int extent = 120, double fill = 0.35) {
  std::vector<ChunkId> ids;
  std::bernoulli_distribution keep(fill);
  for (int x = -extent / 2; x < extent / 2; ++x)
    for (int y = -2; y < 3; ++y)
      for (int z = -extent / 2; z < extent / 2; ++z)
        if (keep(rng)) ids.push_back(chunk_id({x, y, z}));
  return ids;
}

Camera random_camera(std::mt19937& rng) {
  std::uniform_int_distribution<int> w(64, 1280), h(48, 720);
  std::uniform_real_distribution<double> f(0.4, 2.0), c(0.3, 0.7);
  Camera cam;
  cam.width = w(rng);
  cam.height = h(rng);
  cam.fx = f(rng) * cam.width;
  cam.fy = cam.fx * std::uniform_real_distribution<double>(0.9, 1.1)(rng);
  cam.cx = c(rng) * cam.width;
  cam.cy = c(rng) * cam.height;
  return cam;
}

SE3 random_pose(std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  Eigen::Quaterniond q(Eigen::Vector4d::NullaryExpr([&](Eigen::Index) {
    return std::normal_distribution<double>(0, 1)(rng);
  }));
  q.normalize();
  // Half the poses sit exactly on chunk corners or faces, where ties would expose any disagreement.
  Eigen::Vector3d t(u(rng), u(rng) * 0.2, u(rng));
  if (rng() % 2) t = (t / 5.0).array().round() * 5.0;
  return SE3(q, t);
}

}  // namespace

TEST(FrustumCuller, MatchesBruteForceOnThousandsOfRandomPoses) {
  std::mt19937 rng(42);
  const std::vector<ChunkId> ids = random_map(rng);
  for (size_t parallel_min : {size_t(1) << 40, size_t(1)}) {  // serial, then parallel walk
    CullerConfig cfg;
    cfg.parallel_min_chunks = parallel_min;
    cfg.far_level_distance = 0;  // the cubes' visibility (levels: LevelsMatchBruteForce... below)
    FrustumCuller culler(10.0, cfg);
    culler.set_chunks(ids, 1);
    // Fewer poses on the threaded path: on a loaded machine each parallel region can cost ms.
    const int poses = parallel_min > 1 ? 1500 : 300;
    size_t total_visible = 0;
    for (int i = 0; i < poses; ++i) {
      const Camera cam = random_camera(rng);
      const SE3 pose = random_pose(rng, 700);
      const auto fast = culler.cull(cam, pose), slow = culler.cull_brute_force(cam, pose);
      ASSERT_EQ(fast, slow) << "pose " << i << " at " << pose.t.transpose();
      total_visible += fast.size();
    }
    EXPECT_GT(total_visible, size_t(poses) * 10) << "poses should see many chunks";
    EXPECT_LT(culler.stats().node_tests, poses * ids.size() / 4) << "the hierarchy should skip most chunks";
  }
}

TEST(FrustumCuller, MatchesBruteForceWithOddSizesAndShortDistances) {
  std::mt19937 rng(5);
  const std::vector<ChunkId> ids = random_map(rng, 40, 0.6);
  for (double s : {0.7, 3.0, 25.0}) {
    CullerConfig cfg;
    cfg.far = std::uniform_real_distribution<double>(5, 300)(rng);
    cfg.max_distance = std::uniform_real_distribution<double>(3, 200)(rng);
    FrustumCuller culler(s, cfg);
    culler.set_chunks(ids, 1);
    for (int i = 0; i < 800; ++i) {
      const Camera cam = random_camera(rng);
      const SE3 pose = random_pose(rng, 25 * s);
      ASSERT_EQ(culler.cull(cam, pose), culler.cull_brute_force(cam, pose)) << "s=" << s << " pose " << i;
    }
  }
}

TEST(FrustumCuller, NeverMissesAChunkContainingAVisiblePoint) {
  std::mt19937 rng(9);
  const std::vector<ChunkId> ids = random_map(rng, 30, 1.0);  // every chunk present
  CullerConfig one_level;
  one_level.far_level_distance = 0;
  FrustumCuller culler(10.0, one_level);
  culler.set_chunks(ids, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  for (int i = 0; i < 300; ++i) {
    const Camera cam = random_camera(rng);
    const SE3 pose = random_pose(rng, 100);
    const auto vis = culler.cull(cam, pose);
    const std::set<ChunkId> visible(vis.begin(), vis.end());
    for (int k = 0; k < 50; ++k) {
      // A random pixel at a random depth within near/far and the distance limit.
      const Eigen::Vector2d px(u01(rng) * (cam.width - 1), u01(rng) * (cam.height - 1));
      const double depth = 0.1 + u01(rng) * 60;
      const Eigen::Vector3d p = pose * cam.unproject(px, depth);
      if ((p - pose.t).norm() > culler.config().max_distance) continue;  // the distance filter's to drop
      const ChunkCoord c = chunk_coord_of(p, 10.0);
      if (std::abs(c.x) >= 15 || c.y < -2 || c.y > 2 || std::abs(c.z) >= 15) continue;
      ASSERT_TRUE(visible.count(chunk_id(c))) << "point " << p.transpose() << " seen by pose " << i;
    }
  }
}

TEST(FrustumCuller, DropsChunksBehindTheCameraAndBeyondTheDistance) {
  std::vector<ChunkId> ids;
  for (int z = -20; z <= 20; ++z) ids.push_back(chunk_id({0, 0, z}));
  CullerConfig cfg;
  cfg.max_distance = 50;
  FrustumCuller culler(10.0, cfg);
  culler.set_chunks(ids, 1);
  const Camera cam(640, 480, 500, 500, 319.5, 239.5);
  const auto vis = culler.cull(cam, SE3());  // looking down +z from the origin
  std::vector<ChunkId> want;
  for (int z = 0; z <= 5; ++z) want.push_back(chunk_id({0, 0, z}));  // nearest face of chunk 5 at 45 m
  std::sort(want.begin(), want.end());
  EXPECT_EQ(vis, want);
}

TEST(FrustumCuller, DrawsEachCubeAtTheLevelItsDistanceChoosesWhereTheMapHoldsIt) {
  // Cubes down +z, centres 0-90 m ahead; cube 2 has only its far level, cube 8 only its near one.
  std::vector<ChunkId> ids;
  for (int z = 0; z <= 9; ++z) {
    if (z != 2) ids.push_back(chunk_id({0, 0, z}));
    if (z != 8) ids.push_back(far_level_of(chunk_id({0, 0, z})));
  }
  const Camera cam(640, 480, 500, 500, 319.5, 239.5);
  CullerConfig cfg;
  cfg.far_level_distance = 45;
  FrustumCuller culler(10.0, cfg);
  culler.set_chunks(ids, 1);
  std::vector<ChunkId> want;
  for (int z = 0; z <= 4; ++z)
    if (z != 2) want.push_back(chunk_id({0, 0, z}));  // a missing level is left to the sampler, not replaced
  for (int z = 5; z <= 9; ++z)
    if (z != 8) want.push_back(far_level_of(chunk_id({0, 0, z})));
  std::sort(want.begin(), want.end());
  EXPECT_EQ(culler.cull(cam, SE3()), want);
  EXPECT_EQ(culler.cull_brute_force(cam, SE3()), want);
  // The camera 40 m further on: cube 5 (centre 10 m away) is near now.
  const SE3 ahead(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 40));
  const auto vis = culler.cull(cam, ahead);
  EXPECT_TRUE(std::binary_search(vis.begin(), vis.end(), chunk_id({0, 0, 5})));
  EXPECT_FALSE(std::binary_search(vis.begin(), vis.end(), far_level_of(chunk_id({0, 0, 5}))));
  // One level: every cube near, and the cube with only a far level not drawn.
  cfg.far_level_distance = 0;
  FrustumCuller flat(10.0, cfg);
  flat.set_chunks(ids, 1);
  want.clear();
  for (int z = 0; z <= 9; ++z)
    if (z != 2) want.push_back(chunk_id({0, 0, z}));
  std::sort(want.begin(), want.end());
  EXPECT_EQ(flat.cull(cam, SE3()), want);
}

TEST(FrustumCuller, LevelsMatchBruteForceAndTheDistanceRuleOnRandomPoses) {
  std::mt19937 rng(77);
  std::vector<ChunkId> ids = random_map(rng, 60, 0.5);
  std::bernoulli_distribution also_far(0.6);
  const size_t near_count = ids.size();
  for (size_t i = 0; i < near_count; ++i)
    if (also_far(rng)) ids.push_back(far_level_of(ids[i]));
  std::vector<ChunkId> sorted_ids = ids;
  std::sort(sorted_ids.begin(), sorted_ids.end());
  for (double d : {15.0, 42.5, 70.0}) {
    CullerConfig cfg;
    cfg.far_level_distance = d;
    FrustumCuller culler(10.0, cfg);
    culler.set_chunks(ids, 1);
    size_t far_seen = 0, near_seen = 0;
    for (int i = 0; i < 300; ++i) {
      const Camera cam = random_camera(rng);
      const SE3 pose = random_pose(rng, 250);
      const auto fast = culler.cull(cam, pose);
      ASSERT_EQ(fast, culler.cull_brute_force(cam, pose)) << "d=" << d << " pose " << i;
      for (ChunkId id : fast) {
        ASSERT_TRUE(std::binary_search(sorted_ids.begin(), sorted_ids.end(), id));
        const double centre = (chunk_centre(chunk_coord(id), 10.0) - pose.t).norm();  // float64 reference
        ASSERT_EQ(is_far_level(id), centre > d) << chunk_name(id) << " at " << centre << " m, d=" << d;
        (is_far_level(id) ? far_seen : near_seen)++;
      }
    }
    EXPECT_GT(far_seen, 100u) << "d=" << d;
    EXPECT_GT(near_seen, 100u) << "d=" << d;
  }
}

TEST(FrustumCuller, CachesPerKeyframeWhileThePoseMovesLittle) {
  std::mt19937 rng(1);
  FrustumCuller culler(10.0);
  culler.set_chunks(random_map(rng, 40), 7);
  const Camera cam(640, 480, 500, 500, 319.5, 239.5);
  const SE3 pose(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 2));
  const auto first = culler.cull_cached(3, cam, pose);
  const SE3 nudged(Eigen::Quaterniond(Eigen::AngleAxisd(0.04, Eigen::Vector3d::UnitY())), pose.t + Eigen::Vector3d(0.4, 0, 0));
  EXPECT_EQ(culler.cull_cached(3, cam, nudged), first);
  EXPECT_EQ(culler.stats().cache_hits, 1u);
  const SE3 moved(pose.q, pose.t + Eigen::Vector3d(0.6, 0, 0));  // 0.06 s: beyond the threshold
  culler.cull_cached(3, cam, moved);
  EXPECT_EQ(culler.stats().cache_hits, 1u);
  const SE3 turned(Eigen::Quaterniond(Eigen::AngleAxisd(0.06, Eigen::Vector3d::UnitY())), pose.t);
  culler.cull_cached(4, cam, pose);
  culler.cull_cached(4, cam, turned);
  EXPECT_EQ(culler.stats().cache_hits, 1u);
  // A changed chunk set invalidates, an unchanged version does not rebuild or invalidate.
  culler.cull_cached(5, cam, pose);
  std::vector<ChunkId> more{chunk_id({0, 0, 3})};
  culler.set_chunks(more, 8);
  EXPECT_EQ(culler.cull_cached(5, cam, pose), culler.cull_brute_force(cam, pose));
  EXPECT_EQ(culler.stats().cache_hits, 1u);
}

TEST(FrustumCuller, EmptyMapSeesNothing) {
  FrustumCuller culler(10.0);
  culler.set_chunks({}, 1);
  EXPECT_TRUE(culler.cull(Camera(64, 48, 50, 50, 32, 24), SE3()).empty());
}
