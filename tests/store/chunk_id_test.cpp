#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "chungs/common/error.hpp"
#include "chungs/store/chunk_id.hpp"

using namespace chungs;

TEST(ChunkId, RoundTripsRandomCoordinates) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int32_t> d(kChunkCoordMin, kChunkCoordMax);
  for (int i = 0; i < 100000; ++i) {
    ChunkCoord c{d(rng), d(rng), d(rng)};
    EXPECT_EQ(chunk_coord(chunk_id(c)), c);
  }
}

TEST(ChunkId, ExtremesPackToDistinctIds) {
  const int32_t v[] = {kChunkCoordMin, -1, 0, 1, kChunkCoordMax};
  std::set<ChunkId> ids;
  for (int32_t x : v)
    for (int32_t y : v)
      for (int32_t z : v) {
        const ChunkId id = chunk_id({x, y, z});
        EXPECT_LT(id, uint64_t(1) << 63);
        ids.insert(id);
      }
  EXPECT_EQ(ids.size(), 125u);
  EXPECT_EQ(chunk_id({0, 0, 0}), (uint64_t(1) << 62) | (uint64_t(1) << 41) | (uint64_t(1) << 20));
}

TEST(ChunkId, RejectsOutOfRangeCoordinateInsteadOfWrapping) {
  EXPECT_THROW(chunk_id({kChunkCoordMax + 1, 0, 0}), Error);
  EXPECT_THROW(chunk_id({0, kChunkCoordMin - 1, 0}), Error);
  EXPECT_THROW(chunk_id({0, 0, 1 << 30}), Error);
  EXPECT_THROW(chunk_coord_of({1e7 * 10, 0, 0}, 10.0), Error);
  EXPECT_THROW(chunk_coord_of({0, -1e30, 0}, 10.0), Error);
  EXPECT_NO_THROW(chunk_coord_of({(kChunkCoordMax + 0.4) * 10.0, 0, 0}, 10.0));
  EXPECT_THROW(chunk_coord_of({(kChunkCoordMax + 0.6) * 10.0, 0, 0}, 10.0), Error);
  try {
    chunk_id({kChunkCoordMax + 1, 2, 3});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("(1048576, 2, 3)"), std::string::npos) << e.what();
  }
}

TEST(ChunkId, RejectsNonFinitePointsAndBadSizes) {
  EXPECT_THROW(chunk_coord_of({std::nan(""), 0, 0}, 10.0), Error);
  EXPECT_THROW(chunk_coord_of({0, INFINITY, 0}, 10.0), Error);
  EXPECT_THROW(chunk_coord_of({0, 0, 0}, 0.0), Error);
  EXPECT_THROW(chunk_coord_of({0, 0, 0}, -1.0), Error);
}

TEST(ChunkId, ChunksAreCentredOnMultiplesOfTheSize) {
  const double s = 10.0;
  EXPECT_EQ(chunk_coord_of({0, 0, 0}, s), (ChunkCoord{0, 0, 0}));
  EXPECT_EQ(chunk_coord_of({4.999, -4.999, 5.0}, s), (ChunkCoord{0, 0, 1}));
  EXPECT_EQ(chunk_coord_of({-5.0, -5.001, 14.99}, s), (ChunkCoord{0, -1, 1}));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1e4, 1e4);
  for (int i = 0; i < 10000; ++i) {
    Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const ChunkCoord c = chunk_coord_of(p, 2.5);
    Eigen::Vector3d lo, hi;
    chunk_box(c, 2.5, lo, hi);
    for (int a = 0; a < 3; ++a) {
      EXPECT_LE(lo[a], p[a] + 1e-9);
      EXPECT_LT(p[a], hi[a] + 1e-9);
    }
    EXPECT_LE((p - chunk_centre(c, 2.5)).cwiseAbs().maxCoeff(), 1.25 + 1e-9);
  }
}

TEST(ChunkId, BoxOfARunSharesCornersWithItsEndChunks) {
  Eigen::Vector3d lo, hi, lo1, hi1, lo2, hi2;
  chunk_box({-3, 2, 7}, {4, 9, 8}, 10.0, lo, hi);
  chunk_box({-3, 2, 7}, 10.0, lo1, hi1);
  chunk_box({4, 9, 8}, 10.0, lo2, hi2);
  EXPECT_EQ(lo, lo1);
  EXPECT_EQ(hi, hi2);
}

TEST(ChunkId, TheFarLevelIsTheSameCubeWithTheTopBitSet) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int32_t> d(kChunkCoordMin, kChunkCoordMax);
  for (int i = 0; i < 10000; ++i) {
    const ChunkCoord c{d(rng), d(rng), d(rng)};
    const ChunkId near = chunk_id(c), far = far_level_of(near);
    EXPECT_FALSE(is_far_level(near));
    EXPECT_TRUE(is_far_level(far));
    EXPECT_NE(near, far);
    EXPECT_EQ(chunk_coord(far), c);
    EXPECT_EQ(near_level_of(far), near);
    EXPECT_EQ(far_level_of(far), far);
  }
  const ChunkId id = chunk_id({4, -2, 7});
  EXPECT_EQ(chunk_name(id).find(" far"), std::string::npos);
  EXPECT_NE(chunk_name(far_level_of(id)).find("(4, -2, 7) far/0x"), std::string::npos) << chunk_name(far_level_of(id));
}

TEST(ChunkId, AViewDrawsTheFarLevelOfCubesWhoseCentreLiesBeyondTheDistance) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-300, 300), dist(1, 150), size(0.5, 25);
  for (int i = 0; i < 20000; ++i) {
    const double s = size(rng), far = dist(rng);
    const Eigen::Vector3d p(u(rng), u(rng) * 0.1, u(rng)), eye(u(rng), u(rng) * 0.1, u(rng));
    const ChunkCoord c = chunk_coord_of(p, s);
    // float64 reference: the cube's centre, c * s, against the eye
    const double dx = c.x * s - eye.x(), dy = c.y * s - eye.y(), dz = c.z * s - eye.z();
    const bool want_far = std::sqrt(dx * dx + dy * dy + dz * dz) > far;
    const ChunkGrid grid(s, far);
    const ChunkId got = grid.for_view(p, eye);
    ASSERT_EQ(is_far_level(got), want_far) << "point " << p.transpose() << " eye " << eye.transpose();
    ASSERT_EQ(chunk_coord(got), c);
    // Either level in, the same answer; one level (0) always near.
    ASSERT_EQ(level_for_view(far_level_of(chunk_id(c)), eye, s, far), got);
    ASSERT_EQ(level_for_view(got, eye, s, 0), chunk_id(c));
    ASSERT_EQ(ChunkGrid(s).for_view(p, eye), chunk_id(c));
  }
}
