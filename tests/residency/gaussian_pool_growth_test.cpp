// The pool's arrays grow on demand (issue 21: every run took ~1.3 GB for the default budget's pool
// whatever the map held): slots keep their Gaussians across growth, the capacity stays the limit,
// and a growth that cannot get its memory leaves the pool as it was.
#include <gtest/gtest.h>

#include <new>
#include <utility>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/residency/gaussian_pool.hpp"
#include "memory_limit.hpp"
#include "store/random_block.hpp"

using namespace chungs;

namespace {

// Each chunk's slots and the block scattered into them.
using Loaded = std::vector<std::pair<std::vector<uint32_t>, GaussianBlock>>;

bool all_intact(const GaussianPool& pool, const Loaded& loaded) {
  for (const auto& [slots, block] : loaded) {
    GaussianBlock out;
    pool.gather(slots, out);
    if (!test::same_bits(out, block)) return false;
  }
  return true;
}

}  // namespace

TEST(GaussianPoolGrowth, StartsSmallWhateverItsCapacity) {
  CpuGaussianPool pool(1'875'000);  // the default budget plus headroom: ~1.3 GB if allocated up front
  EXPECT_EQ(pool.capacity(), 1'875'000u);
  EXPECT_EQ(pool.allocated(), GaussianPool::kInitialSlots);
  EXPECT_EQ(pool.storage().size(), GaussianPool::kInitialSlots);
  EXPECT_EQ(pool.free_count(), 1'875'000u);
  CpuGaussianPool tiny(100);
  EXPECT_EQ(tiny.allocated(), 100u);
}

TEST(GaussianPoolGrowth, SlotsKeepTheirGaussiansAcrossEveryGrowth) {
  const size_t capacity = 100'000;
  CpuGaussianPool pool(capacity);
  Loaded loaded;
  std::vector<size_t> sizes;
  uint64_t seed = 1;
  // 3000 fit the first arrays; 3000 more double them; 40000 more take what they need; then past
  // half the capacity the arrays take all of it.
  for (size_t n : {3000, 3000, 40'000, 10'000, 2000}) {
    auto slots = pool.allocate(n);
    loaded.emplace_back(slots, test::random_block(n, seed++));
    pool.scatter(loaded.back().second, slots);
    sizes.push_back(pool.allocated());
    ASSERT_TRUE(all_intact(pool, loaded)) << "after growing to " << pool.allocated();
    EXPECT_EQ(pool.storage().size(), pool.allocated());
  }
  EXPECT_EQ(sizes, (std::vector<size_t>{4096, 8192, 46'000, capacity, capacity}));
  // The slots of a fresh pool are handed out lowest first, so the arrays hold just what is used.
  EXPECT_EQ(loaded[2].first.back(), 45'999u);
  // Released slots are reused before the arrays would grow.
  pool.release(loaded[2].first);
  auto again = pool.allocate(40'000);
  EXPECT_LT(*std::max_element(again.begin(), again.end()), 46'000u);
}

TEST(GaussianPoolGrowth, TheCapacityStaysTheLimit) {
  CpuGaussianPool pool(10'000);
  const auto a = pool.allocate(9000);
  EXPECT_EQ(pool.allocated(), 10'000u);  // 9000 is past half: the arrays take the whole capacity
  try {
    pool.allocate(1001);
    FAIL() << "allocated beyond the capacity";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("only 1000 of 10000 are free"), std::string::npos) << e.what();
  }
  EXPECT_EQ(pool.used(), 9000u);
  EXPECT_EQ(pool.allocate(1000).back(), 9999u);
  EXPECT_EQ(pool.free_count(), 0u);
  EXPECT_EQ(pool.allocated(), 10'000u);
  const std::vector<uint32_t> beyond{10'000};
  EXPECT_THROW(pool.release(beyond), Error);
}

TEST(GaussianPoolGrowth, AGrowthWithoutMemoryLeavesThePoolAsItWas) {
  // In a child whose address space may grow by 512 MB: 4 M slots need ~2.9 GB.
  const auto r = test::run_with_memory_limit(size_t(512) << 20, [] {
    CpuGaussianPool pool(8'000'000);
    const auto slots = pool.allocate(1000);
    const Loaded loaded{{slots, test::random_block(1000, 9)}};
    pool.scatter(loaded[0].second, slots);
    try {
      pool.allocate(4'000'000);
      fail("4 M slots were allocated under the memory limit");
    } catch (const std::bad_alloc&) {
    }
    if (pool.used() != 1000 || pool.allocated() != GaussianPool::kInitialSlots ||
        pool.storage().size() != GaussianPool::kInitialSlots || !all_intact(pool, loaded))
      fail("the pool changed: used ", pool.used(), ", allocated ", pool.allocated());
    if (pool.allocate(2000).front() != 1000) fail("the next allocation did not continue at slot 1000");
  });
  EXPECT_EQ(r.outcome, "returned") << r.describe();
}
