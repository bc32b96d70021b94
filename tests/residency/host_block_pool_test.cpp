// HostBlockPool: the host memory for chunks in flight never grows past its size, freed ranges are
// used again (merged with their neighbours), blocks keep their values while others come and go on
// other threads, and a block of the pool goes through a chunk file and the Gaussian pool exactly as a
// GaussianBlock does.
#include "chungs/residency/host_block_pool.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <random>
#include <thread>
#include <vector>

#include "chungs/residency/gaussian_pool.hpp"
#include "chungs/store/chunk_store.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {

// Fills every value of the block from `seed`, so that any overlap with another block shows.
void fill(HostBlock& b, uint32_t seed) {
  const BlockArrays& a = b.arrays();
  for (int k = 0; k < kBlockArrays; ++k) {
    auto* v = static_cast<uint32_t*>(a.data[size_t(k)]);
    for (size_t i = 0; i < a.values(k); ++i) v[i] = seed * 2654435761u + uint32_t(k) * 40503u + uint32_t(i);
  }
}
bool holds(const HostBlock& b, uint32_t seed) {
  const ConstBlockArrays a = b.arrays();
  for (int k = 0; k < kBlockArrays; ++k) {
    const auto* v = static_cast<const uint32_t*>(a.data[size_t(k)]);
    for (size_t i = 0; i < a.values(k); ++i)
      if (v[i] != seed * 2654435761u + uint32_t(k) * 40503u + uint32_t(i)) return false;
  }
  return true;
}

// A GaussianBlock's content in a block of the pool.
std::shared_ptr<HostBlock> copy_into(HostBlockPool& pool, const GaussianBlock& g) {
  auto b = pool.make(g.size(), g.sh_degree);
  copy_gaussians(block_arrays(g), 0, g.size(), b->arrays());
  return b;
}
GaussianBlock copy_out(const HostBlock& b) {
  GaussianBlock g;
  g.sh_degree = b.sh_degree();
  g.resize(b.size());
  copy_gaussians(b.arrays(), 0, b.size(), block_arrays(g));
  return g;
}

size_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  size_t pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * 4096;
}

}  // namespace

TEST(HostBlockPool, NeverGrowsPastItsSizeAndCountsWhatTheHeapTook) {
  HostBlockPool pool(1 << 20);
  const size_t capacity = pool.capacity_bytes();
  ASSERT_GE(capacity, size_t(1) << 20);
  std::mt19937 rng(7);
  std::vector<std::shared_ptr<HostBlock>> kept;
  size_t taken = 0;
  for (;;) {
    const size_t n = 1 + rng() % 300;
    auto b = pool.make_in_pool(n, 3);
    if (!b) break;
    EXPECT_TRUE(b->in_pool());
    EXPECT_EQ(b->size(), n);
    taken += HostBlockPool::block_bytes(n);
    kept.push_back(std::move(b));
  }
  while (auto b = pool.make_in_pool(1, 3)) {  // the last small holes too: now nothing fits
    taken += HostBlockPool::block_bytes(1);
    kept.push_back(std::move(b));
  }
  EXPECT_LE(taken, capacity);
  EXPECT_EQ(pool.used_bytes(), taken);
  EXPECT_EQ(pool.peak_used_bytes(), taken);
  EXPECT_EQ(pool.heap_blocks(), 0u);
  // Full: make() still serves, from the heap, and says so; the pool's own use does not move.
  auto extra = pool.make(200, 3);
  ASSERT_TRUE(extra);
  EXPECT_FALSE(extra->in_pool());
  fill(*extra, 99);
  EXPECT_TRUE(holds(*extra, 99));
  EXPECT_EQ(pool.heap_blocks(), 1u);
  EXPECT_EQ(pool.used_bytes(), taken);
  kept.clear();
  extra.reset();
  EXPECT_EQ(pool.used_bytes(), 0u);
  EXPECT_EQ(pool.peak_used_bytes(), taken);
}

TEST(HostBlockPool, FreedRangesAreReusedAndMergedWithTheirNeighbours) {
  const size_t small = 100, unit = HostBlockPool::block_bytes(small);
  HostBlockPool pool(16 * unit);
  const size_t fits = pool.capacity_bytes() / unit;
  std::vector<std::shared_ptr<HostBlock>> blocks;
  for (size_t k = 0; k < fits; ++k) blocks.push_back(pool.make_in_pool(small, 3));
  for (const auto& b : blocks) ASSERT_TRUE(b);
  EXPECT_FALSE(pool.make_in_pool(small, 3));
  // A freed block's range serves the next block of its size: the same memory, recycled.
  const void* third = blocks[3]->arrays().data[0];
  blocks[3].reset();
  auto again = pool.make_in_pool(small, 3);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->arrays().data[0], third);
  blocks[3] = std::move(again);
  // Every other block freed: half the pool is free, but in pieces too small for a larger block ...
  for (size_t k = 0; k < fits; k += 2) blocks[k].reset();
  const size_t larger = 3 * small;
  ASSERT_GT(HostBlockPool::block_bytes(larger), unit);
  EXPECT_FALSE(pool.make_in_pool(larger, 3));
  EXPECT_EQ(pool.heap_blocks(), 0u);  // make_in_pool never takes the heap
  // ... until their neighbours go too, and the pieces merge into one range again.
  for (size_t k = 1; k < fits; k += 2) blocks[k].reset();
  EXPECT_EQ(pool.used_bytes(), 0u);
  auto most = pool.make_in_pool(pool.capacity_bytes() * 9 / 10 / kBlockBytesPerGaussian, 3);
  EXPECT_TRUE(most && most->in_pool());
}

TEST(HostBlockPool, BlocksKeepTheirValuesWhileOthersComeAndGoOnOtherThreads) {
  HostBlockPool pool(32 << 20);
  std::vector<std::thread> threads;
  std::vector<int> bad(4, 0), heap(4, 0);
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      std::mt19937 rng(uint32_t(t) + 1);
      std::vector<std::pair<std::shared_ptr<HostBlock>, uint32_t>> live;
      for (uint32_t round = 0; round < 3000; ++round) {
        if (live.size() < 12 && rng() % 3 != 0) {
          auto b = pool.make(1 + rng() % 400, 3);
          heap[size_t(t)] += !b->in_pool();
          const uint32_t seed = uint32_t(t) * 100000u + round;
          fill(*b, seed);
          live.emplace_back(std::move(b), seed);
        } else if (!live.empty()) {
          const size_t k = rng() % live.size();
          bad[size_t(t)] += !holds(*live[k].first, live[k].second);
          live.erase(live.begin() + std::ptrdiff_t(k));
        }
      }
      for (const auto& [b, seed] : live) bad[size_t(t)] += !holds(*b, seed);
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) EXPECT_EQ(bad[size_t(t)], 0) << "thread " << t;
  // 4 threads x 12 blocks of at most 400 Gaussians (14 MB) fit in 32 MB, holes and all: nothing went
  // to the heap.
  EXPECT_EQ(pool.heap_blocks(), 0u);
  EXPECT_EQ(pool.used_bytes(), 0u);
  EXPECT_LE(pool.peak_used_bytes(), pool.capacity_bytes());
}

TEST(HostBlockPool, BlocksOutliveThePoolObject) {
  std::shared_ptr<HostBlock> b;
  {
    HostBlockPool pool(1 << 20);
    b = pool.make(50, 3);
    fill(*b, 5);
  }
  EXPECT_TRUE(b->in_pool());
  EXPECT_TRUE(holds(*b, 5));
}

TEST(HostBlockPool, ResidentAtOnceAndNoLargerForUse) {
#if !defined(__linux__)
  GTEST_SKIP() << "reads /proc/self/statm";
#else
  constexpr size_t kMb = size_t(1) << 20;
  HostBlockPool pool(64 * kMb);
  const size_t before = resident_bytes();
  pool.make_resident();
  EXPECT_TRUE(pool.resident());
  const size_t after = resident_bytes();
  EXPECT_GT(after, before + 56 * kMb);
  // Filling the whole pool with written blocks takes no more memory than it already holds.
  std::vector<std::shared_ptr<HostBlock>> blocks;
  for (uint32_t k = 0;; ++k) {
    auto b = pool.make_in_pool(1000, 3);
    if (!b) break;
    fill(*b, k);
    blocks.push_back(std::move(b));
  }
  EXPECT_GT(pool.used_bytes(), 56 * kMb);
  EXPECT_LT(resident_bytes(), after + 4 * kMb);
#endif
}

TEST(HostBlockPool, WithoutMemoryEveryBlockComesFromTheHeap) {
  HostBlockPool pool(0);
  EXPECT_EQ(pool.capacity_bytes(), 0u);
  EXPECT_FALSE(pool.make_in_pool(10, 3));
  auto b = pool.make(10, 3);
  ASSERT_TRUE(b);
  EXPECT_FALSE(b->in_pool());
  fill(*b, 1);
  EXPECT_TRUE(holds(*b, 1));
  EXPECT_EQ(pool.heap_blocks(), 1u);
  pool.make_resident();  // nothing to make resident
  EXPECT_FALSE(pool.resident());
  auto empty = pool.make(0, 3);  // an empty chunk takes no memory from either
  EXPECT_EQ(empty->size(), 0u);
  EXPECT_EQ(pool.heap_blocks(), 1u);
}

TEST(HostBlockPool, ABlockRoundTripsThroughAChunkFileAndTheGaussianPool) {
  test::TempDir dir;
  for (const bool half : {false, true}) {
    ChunkStoreConfig sc;
    sc.half_moments = sc.half_sh_rest = half;
    sc.durable = false;
    ChunkStore store(dir.path() / (half ? "half" : "full"), sc);
    HostBlockPool blocks(8 << 20);
    const GaussianBlock g = test::random_block(321, 11);
    const ChunkId a = chunk_id({1, 2, 3}), b = chunk_id({-4, 0, 7});
    // The same content saved once from a pool block and once from the GaussianBlock: the same file.
    auto h = copy_into(blocks, g);
    store.save_arrays(a, h->arrays());
    store.save(b, g);
    h.reset();
    const GaussianBlock via_block = store.load(b);
    if (!half) {
      EXPECT_TRUE(test::same_bits(via_block, g));
    }
    auto read = blocks.make_in_pool(store.count(a), store.sh_degree());
    ASSERT_TRUE(read);
    store.load_into(a, [&](uint64_t, int) { return read->arrays(); });
    EXPECT_TRUE(test::same_bits(copy_out(*read), via_block)) << (half ? "half" : "full");
    // A placement for the wrong count is refused, naming the file.
    auto wrong = blocks.make(store.count(a) - 1, 3);
    try {
      store.load_into(a, [&](uint64_t, int) { return wrong->arrays(); });
      ADD_FAILURE() << "a read into room for fewer Gaussians succeeded";
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(".chunk"), std::string::npos) << e.what();
    }
    // Into the Gaussian pool and back out through pool blocks: the values as they went in.
    CpuGaussianPool pool(1000);
    const std::vector<uint32_t> slots = pool.allocate(read->size());
    pool.scatter(read->arrays(), slots);
    auto back = blocks.make(slots.size(), pool.sh_degree());
    pool.gather(slots, back->arrays());
    EXPECT_TRUE(test::same_bits(copy_out(*back), via_block));
    GaussianBlock gathered;
    pool.gather(slots, gathered);
    EXPECT_TRUE(test::same_bits(gathered, via_block));
  }
}
