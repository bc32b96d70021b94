// Chunks move between the pool and host memory in portions, not one transfer each: on a GPU every
// transfer is a round trip, and a refinement step under a small budget moves ~60 chunks each way.
#include <gtest/gtest.h>

#include <cstring>

#include "chungs/residency/residency.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
ChunkId cid(int x) { return chunk_id({x, 0, 0}); }

// A host pool that counts its transfers.
class CountingPool final : public GaussianPool {
 public:
  explicit CountingPool(size_t capacity) : GaussianPool(capacity) { grow_impl(allocated()); }
  mutable int scatters = 0, gathers = 0;

 protected:
  void grow_impl(size_t slots) override {
    storage_.sh_degree = sh_degree();
    storage_.resize(slots);
  }
  void scatter_impl(const ConstBlockArrays& block, std::span<const uint32_t> slots) override {
    ++scatters;
    move(block_arrays(storage_), block, slots, true);
  }
  void gather_impl(std::span<const uint32_t> slots, const BlockArrays& out) const override {
    ++gathers;
    move(block_arrays(storage_), out, slots, false);
  }
  void scatter_blocks_impl(std::span<const ConstBlockArrays> blocks, std::span<const uint32_t> slots) override {
    ++scatters;
    for (const ConstBlockArrays& b : blocks) {
      move(block_arrays(storage_), b, slots.first(b.count), true);
      slots = slots.subspan(b.count);
    }
  }
  void gather_blocks_impl(std::span<const uint32_t> slots, std::span<const BlockArrays> outs) const override {
    ++gathers;
    for (const BlockArrays& b : outs) {
      move(block_arrays(storage_), b, slots.first(b.count), false);
      slots = slots.subspan(b.count);
    }
  }

 private:
  static void move(const ConstBlockArrays& pool, const ConstBlockArrays& block, std::span<const uint32_t> slots,
                   bool into_pool) {
    for (int a = 0; a < kBlockArrays; ++a) {
      const size_t w = 4 * size_t(kBlockArrayWidths[size_t(a)]);
      auto* p = static_cast<std::byte*>(const_cast<void*>(pool.data[size_t(a)]));
      auto* b = static_cast<std::byte*>(const_cast<void*>(block.data[size_t(a)]));
      for (size_t i = 0; i < slots.size(); ++i) {
        if (into_pool)
          std::memcpy(p + slots[i] * w, b + i * w, w);
        else
          std::memcpy(b + i * w, p + slots[i] * w, w);
      }
    }
  }
  GaussianBlock storage_;
};
}  // namespace

TEST(ResidencyBatches, ManyChunksLoadInOneUploadAndLeaveInOneGatherExactly) {
  test::TempDir dir;
  ChunkStoreConfig sc;
  sc.half_moments = sc.half_sh_rest = false;  // exact round trips
  sc.durable = false;
  ChunkStore store(dir.path(), sc);
  // Two sets of 40 chunks of 7..46 Gaussians; the budget holds one set.
  std::vector<ChunkId> first, second;
  size_t set_size = 0;
  for (int i = 0; i < 40; ++i) {
    store.save(cid(i), test::random_block(size_t(7 + i), uint64_t(i + 1)));
    store.save(cid(100 + i), test::random_block(size_t(7 + i), uint64_t(100 + i)));
    first.push_back(cid(i));
    second.push_back(cid(100 + i));
    set_size += size_t(7 + i);
  }
  CountingPool pool(set_size);
  ResidencyConfig rc;
  rc.budget_gaussians = set_size;
  rc.async_io = false;
  rc.eviction_hysteresis = 0;
  Residency res(store, pool, rc);

  ASSERT_TRUE(res.pin(first).ok);
  EXPECT_EQ(pool.scatters, 1) << "40 chunks in one portion";
  // Change every Gaussian of the first set in the pool, so that what is written back is not the file.
  std::vector<GaussianBlock> changed;
  for (int i = 0; i < 40; ++i) {
    GaussianBlock b = test::random_block(size_t(7 + i), uint64_t(1000 + i));
    pool.scatter(b, res.slots(first[size_t(i)]));
    changed.push_back(std::move(b));
  }
  res.mark_dirty(first);
  res.unpin(first);
  const int scatters_before = pool.scatters, gathers_before = pool.gathers;
  ASSERT_TRUE(res.pin(second).ok);
  EXPECT_EQ(pool.gathers - gathers_before, 1) << "40 modified chunks evicted in one gather";
  EXPECT_EQ(pool.scatters - scatters_before, 1);
  EXPECT_EQ(res.stats().evictions_dirty, 40u);
  for (int i = 0; i < 40; ++i) {
    EXPECT_TRUE(test::same_bits(store.load(first[size_t(i)]), changed[size_t(i)])) << "chunk " << i;
    GaussianBlock now;
    pool.gather(res.slots(second[size_t(i)]), now);
    EXPECT_TRUE(test::same_bits(now, store.load(second[size_t(i)]))) << "chunk " << 100 + i;
  }
  res.unpin(second);
}
