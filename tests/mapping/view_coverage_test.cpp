// ViewCoverage: which chunk each block of a keyframe sees, against a per-pixel float64 reference on a
// random depth map and pose.
#include "chungs/mapping/view_coverage.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <algorithm>
#include <map>
#include <numeric>
#include <set>

#include "chungs/common/error.hpp"

namespace chungs {
namespace {

struct Scene {
  Camera camera{61, 37, 40.0, 41.0, 30.2, 18.1};
  SE3 pose;
  ImageF depth{61, 37, 1};
};

Scene random_scene(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1, 1);
  Scene s;
  s.pose =
      SE3(Eigen::Quaterniond(1, 0.2 * U(rng), 0.2 * U(rng), 0.2 * U(rng)).normalized().toRotationMatrix(),
          Eigen::Vector3d(30 * U(rng), 30 * U(rng), 2 * U(rng)));
  for (float& d : s.depth.vec()) d = float(1.0 + 45.0 * (0.5 + 0.5 * U(rng)));
  for (size_t i = 0; i < s.depth.pixels(); i += 11) s.depth.data()[i] = i % 2 ? 0.f : NAN;  // no depth
  for (size_t i = 5; i < s.depth.pixels(); i += 7) s.depth.data()[i] = -s.depth.data()[i];  // guesses: a surface
  return s;
}

// The chunk a pixel's surface lies in, or none.
std::optional<ChunkId> chunk_seen(const Scene& s, int x, int y, double chunk_size, double fill) {
  double z = std::abs(double(s.depth(x, y)));
  if (!(z > 0) || !std::isfinite(z)) z = fill;
  if (!(z > 0)) return std::nullopt;
  return chunk_id_of(s.pose * s.camera.unproject(Eigen::Vector2d(x, y), z), chunk_size);
}

TEST(ViewCoverage, MaskFollowsTheChunkEachBlockCentreSees) {
  for (double fill : {0.0, 35.0}) {
    const Scene s = random_scene(fill > 0 ? 3 : 4);
    const ViewCoverage v(s.depth, s.camera, s.pose, 5.0, fill);
    ASSERT_GT(v.chunks().size(), 10u);
    // Accept every other chunk of the view.
    std::set<ChunkId> accepted;
    for (size_t i = 0; i < v.chunks().size(); i += 2) accepted.insert(v.chunks()[i]);
    const auto rendered = [&](ChunkId c) { return accepted.count(c) > 0; };
    const Image8 m = v.mask(rendered);
    ASSERT_EQ(m.width(), 61);
    ASSERT_EQ(m.height(), 37);
    size_t blocks = 0, in = 0;
    const int B = ViewCoverage::kBlock;
    for (int y = 0; y < 37; ++y)
      for (int x = 0; x < 61; ++x) {
        const int cx = std::min(x / B * B + B / 2, 60), cy = std::min(y / B * B + B / 2, 36);
        const auto c = chunk_seen(s, cx, cy, 5.0, fill);
        EXPECT_EQ(m(x, y), c && accepted.count(*c) ? 1 : 0) << x << "," << y;
        if (x % B == 0 && y % B == 0) ++blocks, in += c && accepted.count(*c);
      }
    // Blocks that see no surface take the `unseen` value; the others are as above.
    const Image8 kept = v.mask(rendered, true);
    for (int y = 0; y < 37; ++y)
      for (int x = 0; x < 61; ++x) {
        const int cx = std::min(x / B * B + B / 2, 60), cy = std::min(y / B * B + B / 2, 36);
        const auto c = chunk_seen(s, cx, cy, 5.0, fill);
        EXPECT_EQ(kept(x, y), !c || accepted.count(*c) ? 1 : 0) << x << "," << y;
      }
    EXPECT_NEAR(v.coverage(rendered), double(in) / double(blocks), 1e-12);
    EXPECT_GT(in, 0u);
    EXPECT_LT(in, blocks);
    EXPECT_DOUBLE_EQ(v.coverage([](ChunkId) { return true; }) < 1.0, fill == 0.0)
        << "without a fill depth, pixels with no depth are never covered";
  }
}

TEST(ViewCoverage, CoreIsTheFewestLargestChunksShowingTheShare) {
  const Scene s = random_scene(9);
  const ViewCoverage v(s.depth, s.camera, s.pose, 5.0, 35.0);
  const std::vector<uint32_t> n = v.blocks_per_chunk();
  ASSERT_EQ(n.size(), v.chunks().size());
  ASSERT_GT(n.size(), 10u);
  // Blocks per chunk against the per-pixel reference at the block centres.
  std::map<ChunkId, uint32_t> ref;
  const int B = ViewCoverage::kBlock;
  for (int y = 0; y < 37; y += B)
    for (int x = 0; x < 61; x += B)
      if (const auto c = chunk_seen(s, std::min(x + B / 2, 60), std::min(y + B / 2, 36), 5.0, 35.0)) ++ref[*c];
  for (size_t i = 0; i < n.size(); ++i) EXPECT_EQ(n[i], ref[v.chunks()[i]]);
  const double total = std::accumulate(n.begin(), n.end(), 0.0);
  for (double share : {0.3, 0.6, 0.9, 1.0}) {
    const std::vector<ChunkId> core = v.core(share);
    ASSERT_TRUE(std::is_sorted(core.begin(), core.end()));
    double in = 0;
    uint32_t least_in = UINT32_MAX, most_out = 0;
    for (size_t i = 0; i < n.size(); ++i)
      if (std::binary_search(core.begin(), core.end(), v.chunks()[i]))
        in += n[i], least_in = std::min(least_in, n[i]);
      else
        most_out = std::max(most_out, n[i]);
    EXPECT_GE(in, share * total) << share;
    EXPECT_LT(in - least_in, share * total) << share << ": one chunk fewer would do";
    EXPECT_GE(least_in, most_out) << share << ": a smaller chunk taken before a larger one";
    EXPECT_EQ(core.size() == n.size(), share == 1.0 || most_out == 0) << share;
  }
}

TEST(ViewCoverage, BlocksBeyondTheFarLevelDistanceSeeTheFarLevelOfTheirCube) {
  const Scene s = random_scene(12);
  const double far = 22.0;
  const ViewCoverage flat(s.depth, s.camera, s.pose, 5.0, 35.0);
  const ViewCoverage v(s.depth, s.camera, s.pose, ChunkGrid(5.0, far), 35.0);
  size_t far_chunks = 0;
  for (ChunkId id : v.chunks()) {
    const double centre = (chunk_centre(chunk_coord(id), 5.0) - s.pose.t).norm();
    EXPECT_EQ(is_far_level(id), centre > far) << chunk_name(id) << " at " << centre << " m";
    far_chunks += is_far_level(id);
  }
  EXPECT_GT(far_chunks, 3u);
  EXPECT_LT(far_chunks, v.chunks().size());
  // The same blocks per cube as with one level: only the level differs.
  std::map<ChunkId, uint32_t> one, two;
  for (size_t i = 0; i < flat.chunks().size(); ++i) one[flat.chunks()[i]] = flat.blocks_per_chunk()[i];
  for (size_t i = 0; i < v.chunks().size(); ++i) two[near_level_of(v.chunks()[i])] = v.blocks_per_chunk()[i];
  EXPECT_EQ(one, two);
}

TEST(ViewCoverage, RefusesADepthMapOfAnotherSize) {
  const Scene s = random_scene(5);
  EXPECT_THROW(ViewCoverage(ImageF(60, 37, 1), s.camera, s.pose, 10.0, 0.0), Error);
}

TEST(ViewCoverage, EmptyCoverageAcceptsNothing) {
  const ViewCoverage v;
  EXPECT_TRUE(v.empty());
  EXPECT_EQ(v.coverage([](ChunkId) { return true; }), 0.0);
}

}  // namespace
}  // namespace chungs
