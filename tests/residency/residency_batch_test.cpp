// Chunks move between the pool and host memory in portions, not one transfer each: on a GPU every
// transfer is a round trip, and a refinement step under a small budget moves ~60 chunks each way.
#include <gtest/gtest.h>

#include <cstring>

#include "chungs/common/error.hpp"
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

namespace {
// A map of 10 chunks on disk (ids 0..9, 20..29 Gaussians), and residency over it with `budget`.
struct AddRig {
  test::TempDir dir;
  ChunkStore store;
  CountingPool pool;
  Residency res;
  static ChunkStoreConfig exact() {
    ChunkStoreConfig sc;
    sc.half_moments = sc.half_sh_rest = false;
    sc.durable = false;
    return sc;
  }
  static ResidencyConfig config(size_t budget) {
    ResidencyConfig rc;
    rc.budget_gaussians = budget;
    rc.async_io = false;
    return rc;
  }
  explicit AddRig(size_t budget) : store(dir.path(), exact()), pool(budget), res((seed(store), store), pool, config(budget)) {}
  static void seed(ChunkStore& s) {
    for (int i = 0; i < 10; ++i) s.save(cid(i), test::random_block(size_t(20 + i), uint64_t(50 + i)));
  }
};

// Additions to on-disk, resident, new and twice-named chunks, with the first five chunks resident and
// modified beforehand.
std::vector<std::pair<ChunkId, GaussianBlock>> additions(Residency& res, GaussianPool& pool) {
  std::vector<ChunkId> warm = {cid(0), cid(1), cid(2), cid(3), cid(4)};
  EXPECT_TRUE(res.pin(warm).ok);
  for (size_t i = 0; i < warm.size(); ++i)
    pool.scatter(test::random_block(res.slots(warm[i]).size(), 300 + i), res.slots(warm[i]));
  res.mark_dirty(warm);
  res.unpin(warm);
  std::vector<std::pair<ChunkId, GaussianBlock>> out;
  const int targets[] = {1, 3, 6, 8, 9, 40, 41, 6, 42};  // resident, on disk, new, 6 twice
  for (int k = 0; k < 9; ++k) out.emplace_back(cid(targets[k]), test::random_block(size_t(3 + 2 * k), uint64_t(700 + k)));
  return out;
}

std::vector<ChunkAddition> view(const std::vector<std::pair<ChunkId, GaussianBlock>>& adds) {
  std::vector<ChunkAddition> out;
  for (const auto& [id, b] : adds) out.push_back({id, &b});
  return out;
}
}  // namespace

TEST(ResidencyBatches, AKeyframesAdditionsMoveInOneUploadAndLeaveTheMapOneByOneAddsWould) {
  for (const size_t budget : {size_t(1000), size_t(260)}) {  // all of it; about half the map, so chunks go
    AddRig one(budget), many(budget);
    const auto adds_one = additions(one.res, one.pool), adds_many = additions(many.res, many.pool);
    for (const auto& [id, b] : adds_one) ASSERT_TRUE(one.res.add(id, b).ok);
    const int scatters = many.pool.scatters, gathers = many.pool.gathers;
    const std::vector<PinResult> r = many.res.add_many(view(adds_many));
    ASSERT_EQ(r.size(), adds_many.size());
    for (const PinResult& p : r) EXPECT_TRUE(p.ok) << p.message;
    // One upload of the chunks read back, one of the new Gaussians, at most one gather of the evicted.
    EXPECT_LE(many.pool.scatters - scatters, 2) << "budget " << budget;
    EXPECT_LE(many.pool.gathers - gathers, 1) << "budget " << budget;
    EXPECT_EQ(many.res.catalogue(), one.res.catalogue()) << "budget " << budget;
    EXPECT_LE(many.res.resident_gaussians(), budget);
    if (budget < 300) EXPECT_GT(many.res.stats().evictions_dirty, 0u) << "the small budget must evict";
    one.res.flush();
    many.res.flush();
    for (const auto& [id, n] : one.res.catalogue()) {
      const GaussianBlock a = one.store.load(id), b = many.store.load(id);
      EXPECT_EQ(a.size(), n);
      EXPECT_TRUE(test::same_bits(a, b)) << chunk_name(id) << ", budget " << budget;
    }
  }
}

TEST(ResidencyBatches, AdditionsThatDoNotFitTogetherAreKeptOrRefusedEachAsAddWould) {
  AddRig one(60), many(60);
  const ChunkId pinned[] = {cid(0), cid(1)};  // 41 Gaussians pinned, 19 left
  ASSERT_TRUE(one.res.pin(pinned).ok);
  ASSERT_TRUE(many.res.pin(pinned).ok);
  std::vector<std::pair<ChunkId, GaussianBlock>> adds;
  adds.emplace_back(cid(50), test::random_block(12, 1));  // fits alone
  adds.emplace_back(cid(51), test::random_block(15, 2));  // fits alone, not beside the first
  adds.emplace_back(cid(2), test::random_block(3, 3));    // 22 on disk + 3: never fits
  adds.emplace_back(cid(0), test::random_block(4, 4));    // pinned: its own Gaussians already count
  std::vector<PinResult> expected;
  for (const auto& [id, b] : adds) expected.push_back(one.res.add(id, b));
  const std::vector<PinResult> got = many.res.add_many(view(adds));
  ASSERT_EQ(got.size(), expected.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].ok, expected[i].ok) << "addition " << i;
    EXPECT_EQ(got[i].over_budget, expected[i].over_budget) << "addition " << i;
    EXPECT_EQ(got[i].message, expected[i].message) << "addition " << i;
  }
  EXPECT_FALSE(got[2].ok);
  EXPECT_NE(got[2].message.find("would exceed the budget of 60"), std::string::npos) << got[2].message;
  EXPECT_EQ(many.res.catalogue(), one.res.catalogue());
  EXPECT_EQ(many.res.pinned_gaussians(), one.res.pinned_gaussians());
  many.res.unpin(pinned);
  one.res.unpin(pinned);
}

TEST(ResidencyBatches, AnAdditionWithAnInvalidBlockChangesNothing) {
  AddRig rig(1000);
  std::vector<std::pair<ChunkId, GaussianBlock>> adds;
  adds.emplace_back(cid(60), test::random_block(5, 1));
  adds.emplace_back(cid(61), test::random_block(5, 2));
  adds[1].second.adam_steps.pop_back();  // one array shorter than the rest
  const auto before = rig.res.catalogue();
  EXPECT_THROW(rig.res.add_many(view(adds)), chungs::Error);
  EXPECT_EQ(rig.res.catalogue(), before);
  EXPECT_EQ(rig.res.resident_gaussians(), 0u);
}
