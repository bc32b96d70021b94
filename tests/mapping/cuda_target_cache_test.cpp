// Step targets kept in VRAM: the expansion kernel against its CPU twin (host_targets) bit for bit on
// random images with every kind of invalid depth, and the cache's keeping and dropping of keyframes.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/mapping/cuda/target_cache.hpp"

namespace chungs {
namespace {

std::shared_ptr<const KeyframeImages> random_keyframe(int w, int h, int c, bool depth, std::mt19937& rng) {
  auto k = std::make_shared<KeyframeImages>();
  k->color = Image8(w, h, c);
  std::uniform_int_distribution<int> byte(0, 255);
  for (size_t i = 0; i < k->color.size(); ++i) k->color.data()[i] = uint8_t(byte(rng));
  if (depth) {
    k->depth = ImageF(w, h, 1);
    std::uniform_real_distribution<float> U(0, 1);
    const float odd[] = {0.f, -1.5f, std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN(),
                         1e-30f};
    for (size_t i = 0; i < k->depth.size(); ++i)
      k->depth.data()[i] = U(rng) < 0.2f ? odd[i % 5] : 0.3f + 80.f * U(rng);
  }
  return k;
}

template <typename T>
size_t mismatches(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(T)) != 0;
  return n;
}

TEST(CudaTargetCache, ExpansionMatchesHostTargetsBitForBit) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(5);
  const int sizes[][4] = {{37, 23, 3, 1}, {101, 55, 1, 1}, {64, 33, 4, 1}, {5, 3, 3, 0}, {129, 67, 2, 1}};
  cuda::DeviceTargetCache cache(64 << 20);
  cuda::DeviceArray<float> rgb, inv;
  cuda::DeviceArray<uint8_t> mask;
  uint64_t key = 1;
  for (const auto& s : sizes) {
    const auto k = random_keyframe(s[0], s[1], s[2], s[3] != 0, rng);
    for (bool want_depth : {true, false}) {
      const StepTargets st{key++, want_depth, [&] { return k; }};
      const cuda::DeviceTargets t = cache.expand(st, rgb, inv, mask);
      const HostTargets h = host_targets(*k, want_depth);
      EXPECT_EQ(t.width, s[0]);
      EXPECT_EQ(t.height, s[1]);
      ASSERT_EQ(t.depth, h.depth);
      EXPECT_EQ(mismatches(rgb.download(), h.rgb.vec()), 0u) << s[0] << "x" << s[1] << "x" << s[2];
      if (h.depth) {
        EXPECT_EQ(mismatches(inv.download(), h.inv_depth.vec()), 0u);
        EXPECT_EQ(mismatches(mask.download(), h.mask.vec()), 0u);
      }
    }
  }
}

// A cache over keyframes kf[0..]: use(i) expands keyframe i (key i + 1), counting the reads the cache
// asks for and checking the colour target.
struct CacheUse {
  cuda::DeviceTargetCache& cache;
  const std::vector<std::shared_ptr<const KeyframeImages>>& kf;
  cuda::DeviceArray<float> rgb, inv;
  cuda::DeviceArray<uint8_t> mask;
  int loads = 0;
  void operator()(int i) {
    const StepTargets st{uint64_t(i) + 1, true, [this, i] {
                           ++loads;
                           return kf[size_t(i)];
                         }};
    cache.expand(st, rgb, inv, mask);
    EXPECT_EQ(mismatches(rgb.download(), host_targets(*kf[size_t(i)], true).rgb.vec()), 0u) << "keyframe " << i;
  }
};

TEST(CudaTargetCache, KeepsAtMostItsEntriesWhateverTheBytes) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(11);
  std::vector<std::shared_ptr<const KeyframeImages>> kf;
  for (int i = 0; i < 4; ++i) kf.push_back(random_keyframe(24, 16, 3, true, rng));
  cuda::DeviceTargetCache cache(64 << 20, 2);
  CacheUse use{cache, kf};
  use(0), use(1), use(0);
  EXPECT_EQ(use.loads, 2);
  use(2);  // two entries at most: 1, the least recently used, goes
  EXPECT_EQ(cache.entries(), 2u);
  use(0), use(2);
  EXPECT_EQ(use.loads, 3);
  use(1);
  EXPECT_EQ(use.loads, 4);
  cuda::DeviceTargetCache none(64 << 20, 0);  // keeps nothing
  CacheUse use_none{none, kf};
  use_none(0), use_none(0);
  EXPECT_EQ(none.entries(), 0u);
  EXPECT_EQ(none.uploads(), 2u);
}

TEST(CudaTargetCache, KeepsKeyframesUntilFullThenDropsTheLeastRecentlyUsed) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(9);
  // 40x30x3 colour + depth: 3,600 + 4,800 bytes; room for three.
  std::vector<std::shared_ptr<const KeyframeImages>> kf;
  for (int i = 0; i < 5; ++i) kf.push_back(random_keyframe(40, 30, 3, true, rng));
  const size_t one = kf[0]->bytes();
  cuda::DeviceTargetCache cache(3 * one + one / 2);
  CacheUse use{cache, kf};
  use(0), use(1), use(2);
  EXPECT_EQ(use.loads, 3);
  use(0), use(1), use(2);  // all kept: no load
  EXPECT_EQ(use.loads, 3);
  EXPECT_EQ(cache.entries(), 3u);
  EXPECT_EQ(cache.bytes(), 3 * one);
  use(3);  // full: keyframe 0, the least recently used, goes
  EXPECT_EQ(use.loads, 4);
  EXPECT_EQ(cache.entries(), 3u);
  use(1), use(2), use(3);
  EXPECT_EQ(use.loads, 4);
  use(0);  // loaded again
  EXPECT_EQ(use.loads, 5);
  EXPECT_LE(cache.bytes(), 3 * one + one / 2);
}

TEST(CudaTargetCache, KeyZeroAndImagesLargerThanTheCacheAreNotKept) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(3);
  const auto small = random_keyframe(20, 10, 3, false, rng), big = random_keyframe(200, 100, 3, true, rng);
  cuda::DeviceTargetCache cache(small->bytes() * 4);
  cuda::DeviceArray<float> rgb, inv;
  cuda::DeviceArray<uint8_t> mask;
  int loads = 0;
  for (int i = 0; i < 3; ++i) {
    cache.expand({0, true, [&] { return ++loads, small; }}, rgb, inv, mask);
    const cuda::DeviceTargets t = cache.expand({7, true, [&] { return ++loads, big; }}, rgb, inv, mask);
    EXPECT_TRUE(t.depth);
    EXPECT_EQ(mismatches(inv.download(), host_targets(*big, true).inv_depth.vec()), 0u);
  }
  EXPECT_EQ(loads, 6);
  EXPECT_EQ(cache.entries(), 0u);
  EXPECT_EQ(cache.bytes(), 0u);
}

TEST(CudaTargetCache, DepthOfAnotherSizeIsRefusedAndNothingIsKept) {
  CHUNGS_REQUIRE_GPU();
  auto k = std::make_shared<KeyframeImages>();
  k->color = Image8(8, 6, 3, 10);
  k->depth = ImageF(8, 5, 1, 2.f);
  cuda::DeviceTargetCache cache(1 << 20);
  cuda::DeviceArray<float> rgb, inv;
  cuda::DeviceArray<uint8_t> mask;
  EXPECT_THROW(cache.expand({1, true, [&] { return std::shared_ptr<const KeyframeImages>(k); }}, rgb, inv, mask),
               Error);
  EXPECT_EQ(cache.entries(), 0u);
  EXPECT_EQ(cache.bytes(), 0u);
}

}  // namespace
}  // namespace chungs
#endif
