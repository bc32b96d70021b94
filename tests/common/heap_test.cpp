// keep_heap_for_reuse: the reserve becomes resident at once and stays, and later allocations up to
// its size reuse it instead of growing the process (glibc; elsewhere the call does nothing).
#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "chungs/common/heap.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

using test::resident_bytes;

TEST(Heap, TheReserveIsResidentAtOnceAndReusedAfterwards) {
#if !defined(__GLIBC__) || !defined(__linux__)
  GTEST_SKIP() << "glibc on Linux only";
#else
  constexpr size_t kMb = size_t(1) << 20;
  const size_t before = resident_bytes();
  keep_heap_for_reuse(96 * kMb);
  const size_t reserved = resident_bytes();
  EXPECT_GT(reserved, before + 80 * kMb);  // touched, and not given back when freed
  // Queues filling and draining: blocks of chunk-like sizes, written, freed, again.
  for (int round = 0; round < 3; ++round) {
    std::vector<char*> blocks;
    for (size_t used = 0; used < 72 * kMb; used += 3 * kMb) {
      char* p = static_cast<char*>(std::malloc(3 * kMb));
      ASSERT_NE(p, nullptr);
      for (size_t i = 0; i < 3 * kMb; i += 4096) p[i] = char(round + 1);
      blocks.push_back(p);
    }
    EXPECT_LT(resident_bytes(), reserved + 8 * kMb) << "round " << round;
    for (char* p : blocks) std::free(p);
    EXPECT_GT(resident_bytes(), reserved - 8 * kMb) << "round " << round;  // nothing trimmed
  }
#endif
}

}  // namespace
}  // namespace chungs
