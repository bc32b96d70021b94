// StreetBlocks: worlds that share one cache of city blocks generate each block once for all of
// them, draw the same meshes as a world with a cache of its own, and together never hold more
// than max_blocks blocks, also when they ask from several threads at once.
#include "chungs/synth/street_blocks.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <thread>

#include "chungs/synth/street.hpp"

using namespace chungs;
using namespace chungs::synth;

namespace {
bool same_mesh(const Mesh& a, const Mesh& b) {
  return a.vertices.size() == b.vertices.size() && a.faces.size() == b.faces.size() &&
         std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(a.vertices[0])) == 0;
}
}  // namespace

TEST(StreetBlocks, WorldsSharingACacheGenerateEachBlockOnceAndDrawTheSameMeshes) {
  StreetOptions o;
  o.seed = 21;
  auto shared = std::make_shared<StreetBlocks>(o);
  StreetWorld a(o, shared), b(o, shared), alone(o);
  const Mesh& from_a = a.block(2, -1);
  const Mesh& from_b = b.block(2, -1);
  EXPECT_EQ(&from_a, &from_b);  // one mesh in memory for both
  EXPECT_TRUE(same_mesh(from_a, alone.block(2, -1)));
  EXPECT_EQ(shared->generated(), 1u);
  EXPECT_EQ(alone.blocks_generated(), 1u);  // its own cache: the shared one is not touched
  // Views along a route: whatever world asks first, the other finds the block made.
  o.length_m = 300;
  const Trajectory traj = street_trajectory(o);
  const Camera cam = kitti_camera(160, 48);
  for (size_t i = 0; i < traj.size(); i += 7) (i % 2 ? a : b).gather(cam, traj.poses[i], o.far);
  EXPECT_EQ(shared->generated(), shared->distinct());  // nothing built twice
  EXPECT_EQ(a.blocks_in_memory(), b.blocks_in_memory());
  EXPECT_GT(shared->distinct(), 10u);
}

TEST(StreetBlocks, WorldsOnSeveralThreadsHoldAtMostMaxBlocksTogether) {
  StreetOptions o;
  o.seed = 4;
  o.length_m = 1500;
  o.max_blocks = 24;
  const Trajectory traj = street_trajectory(o);
  const Camera cam = kitti_camera(160, 48);
  auto shared = std::make_shared<StreetBlocks>(o);
  std::vector<std::thread> threads;
  std::vector<size_t> most(3, 0);
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      StreetWorld w(o, shared);
      // Frames handed out in turn, as a prefetching mapper asks for them.
      for (size_t i = size_t(t); i < traj.size(); i += 3 * 11) {
        const auto meshes = w.gather(cam, traj.poses[i], o.far);
        for (const Mesh* m : meshes) ASSERT_GT(m->triangles(), 0u);
        most[size_t(t)] = std::max(most[size_t(t)], shared->in_memory());
      }
    });
  }
  for (auto& th : threads) th.join();
  for (size_t m : most) EXPECT_LE(m, o.max_blocks);
  EXPECT_GT(shared->distinct(), o.max_blocks);  // the route outgrew the cache: blocks were dropped
  // A block dropped and asked for again is built again, the same as before.
  StreetWorld alone(o);
  const Mesh again = *shared->get(0, 0);
  EXPECT_TRUE(same_mesh(again, alone.block(0, 0)));
}
