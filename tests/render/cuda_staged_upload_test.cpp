// StagedUpload: a list written into the pinned buffer it lends goes up as any other, alternating
// uploads keep their own device copies, and a lent buffer overwritten by an upload in between is refused.
// Skipped where no CUDA device is present.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/render/cuda/device_buffer.hpp"
#include "cuda_test_support.hpp"

namespace chungs {
namespace {

std::vector<uint32_t> device_copy(const void* p, size_t n) {
  std::vector<uint32_t> out(n);
  cuda::synchronize("test");
  cuda::copy_to_host(out.data(), p, n * sizeof(uint32_t), "test");
  return out;
}

TEST(CudaStagedUpload, LentBuffersGoUpAndAStaleOneIsRefused) {
  CHUNGS_REQUIRE_GPU();
  cuda::StagedUpload up;
  std::vector<uint32_t> a(50000), b(70000);
  std::iota(a.begin(), a.end(), 7u);
  std::iota(b.begin(), b.end(), 1000003u);
  // Lent, filled, uploaded; then a plain upload; then lent again (the other buffer).
  auto* lent = static_cast<uint32_t*>(up.next_host_buffer(a.size() * 4, "a"));
  std::copy(a.begin(), a.end(), lent);
  const void* da = up.upload(lent, a.size() * 4, "a");
  EXPECT_EQ(device_copy(da, a.size()), a);
  const void* db = up.upload(b.data(), b.size() * 4, "b");
  EXPECT_EQ(device_copy(db, b.size()), b);
  EXPECT_EQ(device_copy(da, a.size()), a) << "the upload before the last keeps its device copy";
  auto* lent2 = static_cast<uint32_t*>(up.next_host_buffer(b.size() * 4, "b"));
  std::copy(b.rbegin(), b.rend(), lent2);
  const void* db2 = up.upload(lent2, b.size() * 4, "b reversed");
  EXPECT_EQ(device_copy(db2, b.size()), std::vector<uint32_t>(b.rbegin(), b.rend()));
  // A buffer lent before another upload: that upload wrote into it, and it is refused.
  auto* stale = static_cast<uint32_t*>(up.next_host_buffer(a.size() * 4, "a"));
  std::copy(a.begin(), a.end(), stale);
  up.upload(b.data(), b.size() * 4, "b in between");
  EXPECT_THROW(up.upload(stale, a.size() * 4, "stale"), Error);
}

}  // namespace
}  // namespace chungs
#endif
