#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "chungs/common/error.hpp"
#include "chungs/residency/gaussian_pool.hpp"
#include "store/random_block.hpp"

using namespace chungs;

TEST(GaussianPool, AllocatesDistinctSlotsAndReusesReleasedOnes) {
  CpuGaussianPool pool(100);
  auto a = pool.allocate(30), b = pool.allocate(70);
  EXPECT_EQ(pool.free_count(), 0u);
  std::set<uint32_t> all(a.begin(), a.end());
  all.insert(b.begin(), b.end());
  EXPECT_EQ(all.size(), 100u);
  EXPECT_EQ(*all.rbegin(), 99u);
  pool.release(a);
  EXPECT_EQ(pool.free_count(), 30u);
  auto c = pool.allocate(30);
  std::sort(a.begin(), a.end());
  std::sort(c.begin(), c.end());
  EXPECT_EQ(a, c);
}

TEST(GaussianPool, RefusesToOverAllocate) {
  CpuGaussianPool pool(10);
  pool.allocate(8);
  EXPECT_THROW(pool.allocate(3), Error);
  EXPECT_EQ(pool.free_count(), 2u);
}

TEST(GaussianPool, RejectsBadReleasesWithoutChangingAnything) {
  CpuGaussianPool pool(10);
  auto a = pool.allocate(4);
  const std::vector<uint32_t> twice{a[0], a[1], a[0]};
  EXPECT_THROW(pool.release(twice), Error);
  EXPECT_EQ(pool.used(), 4u);
  EXPECT_TRUE(pool.in_use(a[0]) && pool.in_use(a[1]));
  const std::vector<uint32_t> free_one{9};
  EXPECT_THROW(pool.release(free_one), Error);
  const std::vector<uint32_t> beyond{10};
  EXPECT_THROW(pool.release(beyond), Error);
  EXPECT_EQ(pool.used(), 4u);
}

TEST(GaussianPool, ScatterThenGatherReturnsTheBlockBitExactly) {
  CpuGaussianPool pool(500);
  pool.allocate(123);  // so the slots below are not 0..n-1
  std::mt19937 rng(1);
  auto slots = pool.allocate(200);
  std::shuffle(slots.begin(), slots.end(), rng);
  const GaussianBlock b = test::random_block(200, 77);
  pool.scatter(b, slots);
  GaussianBlock out;
  pool.gather(slots, out);
  EXPECT_TRUE(test::same_bits(out, b));
  // Raw SoA access sees Gaussian i at slot slots[i].
  EXPECT_EQ(pool.params().opacity[slots[17]], b.params.opacity[17]);
  EXPECT_EQ(pool.storage().adam_v.sh[size_t(slots[5]) * kShFloats + 40], b.adam_v.sh[5 * kShFloats + 40]);
  EXPECT_EQ(pool.storage().created_at_step[slots[199]], b.created_at_step[199]);
}

TEST(GaussianPool, RejectsScatterIntoFreeSlotsOrWrongCount) {
  CpuGaussianPool pool(20);
  auto slots = pool.allocate(5);
  const GaussianBlock b = test::random_block(5, 2);
  std::vector<uint32_t> wrong = slots;
  wrong[2] = 19;  // free
  EXPECT_THROW(pool.scatter(b, wrong), Error);
  EXPECT_THROW(pool.scatter(test::random_block(4, 2), slots), Error);
  GaussianBlock out;
  EXPECT_THROW(pool.gather(wrong, out), Error);
}
