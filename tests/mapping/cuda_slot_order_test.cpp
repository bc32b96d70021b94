// The step's slot list in slot order (mapping/cuda/slot_order.hpp): random scattered slot lists of several
// sizes and capacities come back ascending, each with the place it held, and lists that outgrow the places'
// source or shrink again are sorted as well.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "chungs/mapping/cuda/slot_order.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

TEST(CudaSlotOrder, SortsScatteredSlotsAndKeepsTheirPlaces) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(5);
  cuda::SlotOrder order;
  const size_t cases[][2] = {
      {1000, 5000}, {70000, 300000}, {3, 3}, {250000, 250001}, {40000, (size_t(1) << 24) + 9}};
  for (const auto& [n, capacity] : cases) {
    // n distinct slots below capacity, in random order (as chunks scattered over the pool write them).
    std::vector<uint32_t> ids;
    std::uniform_int_distribution<uint32_t> slot(0, uint32_t(capacity - 1));
    std::vector<uint8_t> taken(capacity, 0);
    while (ids.size() < n) {
      const uint32_t s = slot(rng);
      if (!taken[s]) taken[s] = 1, ids.push_back(s);
    }
    cuda::DeviceArray<uint32_t> d(ids);
    order.sort(d.data(), n, capacity);
    std::vector<uint32_t> sorted(n), places(n);
    cuda::copy_to_host(sorted.data(), order.ids(), n * sizeof(uint32_t), "sorted");
    cuda::copy_to_host(places.data(), order.places(), n * sizeof(uint32_t), "places");
    std::vector<uint32_t> want = ids;
    std::sort(want.begin(), want.end());
    EXPECT_EQ(sorted, want) << n << " slots of " << capacity;
    std::vector<uint8_t> seen(n, 0);
    for (size_t i = 0; i < n; ++i) {
      ASSERT_LT(places[i], n);
      ASSERT_EQ(ids[places[i]], sorted[i]) << "entry " << i << " of " << n;
      seen[places[i]] = 1;
    }
    EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(n));
  }
}

}  // namespace
}  // namespace chungs
#endif
