// MappedAllocator: a phase's large arrays go back to the system when freed, whatever the heap keeps.
#include "chungs/common/mapped_allocator.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <vector>

#include "chungs/common/heap.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

double rss_mb() { return double(test::resident_bytes()) / 1048576.0; }

TEST(MappedAllocator, HoldsWhatAVectorHoldsAndGivesItsMemoryBackWhenFreed) {
  keep_heap_for_reuse(0);  // the mapping run's heap: blocks up to 32 MB from it, freed memory kept
  const double before = rss_mb();
  double grown = 0;
  {
    std::vector<uint32_t, MappedAllocator<uint32_t>> v;
    for (uint32_t i = 0; i < 3'000'000; ++i) v.push_back(i * 2654435761u);  // 12 MB, grown by doubling: every block under 32 MB
    grown = rss_mb() - before;
    uint64_t sum = 0, want = 0;
    for (uint32_t i = 0; i < 3'000'000; ++i) want += uint32_t(i * 2654435761u);
    sum = std::accumulate(v.begin(), v.end(), uint64_t(0));
    EXPECT_EQ(sum, want);
    std::vector<uint32_t, MappedAllocator<uint32_t>> copy = v;  // copies and moves keep the values
    EXPECT_EQ(copy, v);
    auto moved = std::move(copy);
    EXPECT_EQ(moved.back(), v.back());
  }
  EXPECT_GT(grown, 10.0) << "the array was not resident";
  EXPECT_LT(rss_mb() - before, 3.0) << "freed, the array's memory stayed with the process";
}

}  // namespace
}  // namespace chungs
