// The VRAM Gaussian pool behaves as the CPU pool: the same slots hold the same Gaussians after any
// sequence of scatters (loads), releases and gathers (evictions).
#ifdef CHUNGS_WITH_CUDA
#include <cuda_runtime.h>
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <algorithm>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "chungs/cuda/devices.hpp"
#include "chungs/residency/cuda/gaussian_pool.hpp"
#include "chungs/residency/cuda/pool_device.hpp"

namespace chungs {
namespace {

GaussianBlock random_block(size_t n, std::mt19937& rng) {
  std::normal_distribution<float> N(0, 1);
  GaussianBlock b;
  b.resize(n);
  for (auto* p : {&b.params, &b.adam_m, &b.adam_v})
    for (auto* v : {&p->mean, &p->log_scale, &p->rotation, &p->opacity, &p->sh})
      for (float& x : *v) x = N(rng);
  for (size_t i = 0; i < n; ++i) {
    b.adam_steps[i] = uint32_t(rng());
    b.created_by_keyframe[i] = uint32_t(rng());
    b.created_at_step[i] = uint32_t(rng());
    b.lr_position_factor[i] = N(rng);
  }
  return b;
}

void expect_same(const GaussianBlock& a, const GaussianBlock& b) {
  const GaussianParams* pa[3] = {&a.params, &a.adam_m, &a.adam_v};
  const GaussianParams* pb[3] = {&b.params, &b.adam_m, &b.adam_v};
  for (int s = 0; s < 3; ++s) {
    EXPECT_EQ(pa[s]->mean, pb[s]->mean);
    EXPECT_EQ(pa[s]->log_scale, pb[s]->log_scale);
    EXPECT_EQ(pa[s]->rotation, pb[s]->rotation);
    EXPECT_EQ(pa[s]->opacity, pb[s]->opacity);
    EXPECT_EQ(pa[s]->sh, pb[s]->sh);
  }
  EXPECT_EQ(a.adam_steps, b.adam_steps);
  EXPECT_EQ(a.created_by_keyframe, b.created_by_keyframe);
  EXPECT_EQ(a.created_at_step, b.created_at_step);
  EXPECT_EQ(a.lr_position_factor, b.lr_position_factor);
  EXPECT_EQ(a.sh_degree, b.sh_degree);
}

TEST(CudaGaussianPool, MatchesCpuPoolOverLoadsAndEvictions) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(3);
  const size_t capacity = 20000;
  cuda::CudaGaussianPool gpu(capacity, 2);
  CpuGaussianPool cpu(capacity, 2);
  std::vector<std::vector<uint32_t>> chunks;
  // Load chunks of varied size, evict some, load more into the freed slots (several scatters in
  // flight through the alternating staging buffers), then gather everything in shuffled order.
  for (int step = 0; step < 12; ++step) {
    const size_t n = 200 + rng() % 3000;
    if (n > cpu.free_count() || step % 4 == 3) {
      const size_t victim = rng() % chunks.size();
      GaussianBlock a, b;
      gpu.gather(chunks[victim], a);
      cpu.gather(chunks[victim], b);
      expect_same(a, b);
      gpu.release(chunks[victim]);
      cpu.release(chunks[victim]);
      chunks.erase(chunks.begin() + std::ptrdiff_t(victim));
      continue;
    }
    const GaussianBlock blk = random_block(n, rng);
    const auto s1 = gpu.allocate(n), s2 = cpu.allocate(n);
    ASSERT_EQ(s1, s2);
    gpu.scatter(blk, s1);
    cpu.scatter(blk, s2);
    chunks.push_back(s1);
  }
  std::vector<uint32_t> all;
  for (const auto& c : chunks) all.insert(all.end(), c.begin(), c.end());
  std::shuffle(all.begin(), all.end(), rng);
  GaussianBlock a, b;
  gpu.gather(all, a);
  cpu.gather(all, b);
  ASSERT_EQ(a.size(), all.size());
  expect_same(a, b);
}

TEST(CudaGaussianPool, DeviceArraysHoldScatteredSlots) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(4);
  cuda::CudaGaussianPool pool(100);
  const GaussianBlock blk = random_block(10, rng);
  std::vector<uint32_t> slots = pool.allocate(30);
  slots.erase(slots.begin(), slots.begin() + 20);  // slots 20..29
  pool.scatter(blk, slots);
  pool.wait_uploads();
  const cuda::PoolDeviceArrays& d = pool.device_arrays();
  ASSERT_EQ(d.capacity, 100u);
  // Read the device arrays directly (default stream, ordered after the uploads by wait_uploads).
  std::vector<float> sh(size_t(kShFloats) * 10), m(30), steps_f(10);
  std::vector<uint32_t> steps(10);
  ASSERT_EQ(cudaMemcpy(sh.data(), d.sh[0] + size_t(kShFloats) * 20, sh.size() * 4, cudaMemcpyDeviceToHost),
            cudaSuccess);
  ASSERT_EQ(cudaMemcpy(m.data(), d.mean[1] + 3 * 20, m.size() * 4, cudaMemcpyDeviceToHost), cudaSuccess);
  ASSERT_EQ(cudaMemcpy(steps.data(), d.adam_steps + 20, 40, cudaMemcpyDeviceToHost), cudaSuccess);
  EXPECT_EQ(sh, blk.params.sh);
  EXPECT_EQ(m, blk.adam_m.mean);
  EXPECT_EQ(steps, blk.adam_steps);
}

// Batches larger than the fixed staging buffers move in pieces; slots in shuffled order so that a
// piece boundary falling in the wrong place would put Gaussians in the wrong slots.
TEST(CudaGaussianPool, MovesBatchesLargerThanItsStagingInPieces) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(6);
  const size_t piece = cuda::detail::pool_device_piece();
  const size_t n = 2 * piece + 1234;
  cuda::CudaGaussianPool gpu(n + 100, 1);
  CpuGaussianPool cpu(n + 100, 1);
  auto slots = gpu.allocate(n + 100);
  ASSERT_EQ(slots, cpu.allocate(n + 100));
  std::shuffle(slots.begin(), slots.end(), rng);
  slots.resize(n);
  const GaussianBlock blk = random_block(n, rng);
  gpu.scatter(blk, slots);
  cpu.scatter(blk, slots);
  std::shuffle(slots.begin(), slots.end(), rng);
  GaussianBlock a, b;
  gpu.gather(slots, a);
  cpu.gather(slots, b);
  ASSERT_EQ(a.size(), n);
  expect_same(a, b);
}

// Several blocks against one slot list (how residency moves a portion of chunks): block boundaries
// inside and across the staging pieces, an empty block among them, slots shuffled.
TEST(CudaGaussianPool, MovesSeveralBlocksInOneTransferAsTheCpuPoolDoesOneByOne) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(8);
  const size_t piece = cuda::detail::pool_device_piece();
  const std::vector<size_t> sizes = {7, piece - 3, 0, 11, piece + 5, 1};
  size_t n = 0;
  for (size_t k : sizes) n += k;
  cuda::CudaGaussianPool gpu(n, 3);
  CpuGaussianPool cpu(n, 3);
  auto slots = gpu.allocate(n);
  ASSERT_EQ(slots, cpu.allocate(n));
  std::shuffle(slots.begin(), slots.end(), rng);
  std::vector<GaussianBlock> blocks;
  std::vector<ConstBlockArrays> in;
  for (size_t k : sizes) blocks.push_back(random_block(k, rng));
  for (const GaussianBlock& b : blocks) in.push_back(block_arrays(b));
  gpu.scatter(in, slots);
  size_t first = 0;
  for (const GaussianBlock& b : blocks) {
    cpu.scatter(b, std::span(slots).subspan(first, b.size()));
    first += b.size();
  }
  std::shuffle(slots.begin(), slots.end(), rng);
  std::vector<GaussianBlock> outs(sizes.size());
  std::vector<BlockArrays> out;
  for (size_t i = 0; i < sizes.size(); ++i) {
    outs[i].sh_degree = 3;
    outs[i].resize(sizes[i]);
    out.push_back(block_arrays(outs[i]));
  }
  gpu.gather(slots, out);
  first = 0;
  for (size_t i = 0; i < sizes.size(); ++i) {
    GaussianBlock b;
    cpu.gather(std::span(slots).subspan(first, sizes[i]), b);
    first += sizes[i];
    expect_same(outs[i], b);
  }
}

// The arrays grow on demand (issue 21): a growth copies every slot into bigger arrays behind the
// scatters still in flight on the pool's stream, and device_arrays() then names the new arrays.
TEST(CudaGaussianPool, GrowsKeepingEverySlotAndScattersInFlight) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(5);
  cuda::CudaGaussianPool pool(50'000, 3);
  EXPECT_EQ(pool.allocated(), GaussianPool::kInitialSlots);
  EXPECT_EQ(pool.device_arrays().capacity, GaussianPool::kInitialSlots);
  std::vector<std::pair<std::vector<uint32_t>, GaussianBlock>> loaded;
  std::vector<size_t> sizes;
  for (size_t n : {3000, 3000, 20'000, 10'000}) {
    const auto slots = pool.allocate(n);  // no wait: the last scatter may still be in flight
    loaded.emplace_back(slots, random_block(n, rng));
    pool.scatter(loaded.back().second, slots);
    sizes.push_back(pool.allocated());
    EXPECT_EQ(pool.device_arrays().capacity, pool.allocated());
  }
  EXPECT_EQ(sizes, (std::vector<size_t>{4096, 8192, 50'000, 50'000}));
  for (const auto& [slots, block] : loaded) {
    GaussianBlock out;
    pool.gather(slots, out);
    expect_same(out, block);
  }
  // The raw arrays after growth hold what was scattered before it.
  pool.wait_uploads();
  const uint32_t slot = loaded[0].first[1234];
  float opacity = 0;
  ASSERT_EQ(cudaMemcpy(&opacity, pool.device_arrays().opacity[0] + slot, 4, cudaMemcpyDeviceToHost), cudaSuccess);
  EXPECT_EQ(opacity, loaded[0].second.params.opacity[1234]);
}

}  // namespace
}  // namespace chungs
#endif
