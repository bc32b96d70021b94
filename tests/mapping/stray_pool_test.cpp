#include "chungs/mapping/stray_pool.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <initializer_list>
#include <random>
#include <utility>

namespace chungs {
namespace {

// n Gaussians of chunk `id`, marked as created by keyframe `kf` at step 0, with random means.
ChunkBatch batch(ChunkId id, size_t n, uint32_t kf, std::mt19937& rng) {
  ChunkBatch b{id, {}};
  b.block.resize(n);
  std::uniform_real_distribution<float> u(-5.f, 5.f);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) b.block.params.mean[3 * i + k] = u(rng);
    b.block.created_by_keyframe[i] = kf;
    b.block.created_at_step[i] = 0;
  }
  return b;
}

// Batches of the given chunks and sizes, all from keyframe `kf`.
std::vector<ChunkBatch> batches(std::initializer_list<std::pair<ChunkId, size_t>> sizes, uint32_t kf, std::mt19937& rng) {
  std::vector<ChunkBatch> out;
  for (const auto& [id, n] : sizes) out.push_back(batch(id, n, kf, rng));
  return out;
}

const auto none = [](ChunkId) { return false; };

TEST(StrayPool, AChunkIsMadeOnceSeveralKeyframesPicksReachTheThreshold) {
  std::mt19937 rng(5);
  StrayPool pool;
  std::vector<ChunkBatch> a, b, c;
  a.push_back(batch(7, 20, 0, rng));
  const float first_x = a[0].block.params.mean[0];
  EXPECT_TRUE(pool.add(0, std::move(a), 50, 5, 100, none).empty());
  b.push_back(batch(7, 20, 1, rng));
  b.push_back(batch(9, 3, 1, rng));
  EXPECT_TRUE(pool.add(1, std::move(b), 50, 5, 130, none).empty());
  EXPECT_EQ(pool.chunks(), 2u);
  EXPECT_EQ(pool.gaussians(), 43u);
  c.push_back(batch(7, 15, 2, rng));
  const auto out = pool.add(2, std::move(c), 50, 5, 160, none);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].id, 7u);
  ASSERT_EQ(out[0].block.size(), 55u);
  // Every keyframe's picks, the first ones first; training counts from the step the chunk is made.
  EXPECT_EQ(out[0].block.params.mean[0], first_x);
  EXPECT_EQ(out[0].block.created_by_keyframe[0], 0u);
  EXPECT_EQ(out[0].block.created_by_keyframe[54], 2u);
  for (uint32_t s : out[0].block.created_at_step) EXPECT_EQ(s, 160u);
  EXPECT_EQ(pool.chunks(), 1u);
  EXPECT_EQ(pool.gaussians(), 3u);
}

TEST(StrayPool, PicksThatWaitInVainAreForgottenSoThePoolStaysBounded) {
  std::mt19937 rng(6);
  StrayPool pool;
  pool.add(4, batches({{3, 10}}, 4, rng), 50, 3, 0, none);
  EXPECT_EQ(pool.gaussians(), 10u);
  EXPECT_TRUE(pool.add(6, {}, 50, 3, 0, none).empty());
  EXPECT_EQ(pool.chunks(), 1u);  // two keyframes without picks: still waiting
  pool.add(7, {}, 50, 3, 0, none);
  EXPECT_EQ(pool.chunks(), 0u);
  EXPECT_EQ(pool.forgotten(), 10u);
  // Hundreds of keyframes each leaving a few picks in a chunk of its own hold at most `wait` keyframes' worth.
  for (uint32_t kf = 10; kf < 400; ++kf) {
    EXPECT_TRUE(pool.add(kf, batches({{ChunkId(1000 + kf), 4}}, kf, rng), 50, 3, 0, none).empty());
    EXPECT_LE(pool.chunks(), 3u);
  }
}

TEST(StrayPool, AChunkTheMapMadeMeanwhileTakesItsWaitingPicks) {
  std::mt19937 rng(7);
  StrayPool pool;
  pool.add(0, batches({{2, 30}, {3, 10}}, 0, rng), 50, 10, 0, none);
  const auto out = pool.add(1, {}, 50, 10, 0, [](ChunkId id) { return id == 3; });
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].id, 3u);
  EXPECT_EQ(out[0].block.size(), 10u);
  EXPECT_EQ(pool.gaussians(), 30u);
  pool.forget_all();  // a loop correction moved the poses that placed them
  EXPECT_EQ(pool.chunks(), 0u);
  EXPECT_EQ(pool.forgotten(), 30u);
}

TEST(Sampler, ARandomSubsetThinsEveryBatchAlike) {
  std::mt19937 r(8);
  std::vector<ChunkBatch> bs;
  bs.push_back(batch(1, 4000, 0, r));
  bs.push_back(batch(2, 2000, 0, r));
  bs.push_back(batch(3, 1, 0, r));
  std::vector<float> means(bs[1].block.params.mean);
  std::mt19937_64 rng(9);
  std::vector<ChunkBatch> all = bs;
  EXPECT_EQ(keep_random_subset(all, 7001, rng), 0u);
  EXPECT_EQ(all.size(), 3u);
  EXPECT_EQ(keep_random_subset(bs, 3000, rng), 3001u);
  uint64_t n = 0;
  for (const auto& b : bs) n += b.block.size();
  EXPECT_EQ(n, 3000u);
  ASSERT_GE(bs.size(), 2u);
  EXPECT_NEAR(double(bs[0].block.size()), 2000, 120);  // half of each, within a few standard deviations
  EXPECT_NEAR(double(bs[1].block.size()), 1000, 120);
  // Kept Gaussians are copies of the originals, in their order.
  size_t j = 0;
  for (size_t i = 0; i < bs[1].block.size(); ++i) {
    while (j < 2000 && means[3 * j] != bs[1].block.params.mean[3 * i]) ++j;
    EXPECT_LT(j, 2000u);
  }
}

}  // namespace
}  // namespace chungs
