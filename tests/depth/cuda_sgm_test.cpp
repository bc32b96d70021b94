// Semi-global matching on the GPU against its CPU twin (sgm_disparities), bit for bit: random pairs
// at every lane width of the kernels (1 to 8 disparities per lane, counts not a multiple of 32),
// a real KITTI pair at full resolution, and many threads sharing the device workspace.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <algorithm>
#include <random>
#include <thread>

#include "chungs/datasets/dataset.hpp"
#include "chungs/depth/cuda/sgm_cuda.hpp"
#include "chungs/depth/stereo_depth.hpp"

namespace chungs {
namespace {

std::pair<Image8, Image8> textured_pair(int w, int h, int shift, std::mt19937& rng) {
  Image8 l(w, h, 1), r(w, h, 1);
  std::uniform_int_distribution<int> U(0, 255), n(-5, 5);
  for (auto& v : l.vec()) v = uint8_t(U(rng));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) r(x, y) = uint8_t(std::clamp(l(std::min(w - 1, x + shift), y) + n(rng), 0, 255));
  return {l, r};
}

size_t differing(const std::vector<int16_t>& a, const std::vector<int16_t>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += a[i] != b[i];
  return n;
}

TEST(CudaSgm, MatchesTheCpuTwinBitForBit) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(12);
  struct Case { int w, h, shift, D, p1, p2, uniq; };
  for (const Case c : {Case{64, 40, 7, 16, 10, 120, 10}, Case{97, 61, 20, 48, 10, 120, 10},
                       Case{160, 96, 40, 128, 8, 90, 5}, Case{300, 50, 100, 256, 10, 120, 0},
                       Case{33, 70, 3, 70, 12, 200, 20}, Case{5, 3, 1, 3, 10, 120, 10}}) {
    const auto [l, r] = textured_pair(c.w, c.h, c.shift, rng);
    SgmParams p;
    p.disparities = c.D, p.p1 = c.p1, p.p2 = c.p2, p.uniqueness = c.uniq;
    const SgmDisparities gpu = cuda::sgm_disparities(l, r, p), cpu = sgm_disparities(l, r, p);
    EXPECT_EQ(differing(gpu.left, cpu.left), 0u) << c.w << "x" << c.h << " D " << c.D;
    EXPECT_EQ(differing(gpu.right, cpu.right), 0u) << c.w << "x" << c.h << " D " << c.D;
  }
}

TEST(CudaSgm, KittiPairMatchesTheCpuTwinAndTheStereoDepthToo) {
  CHUNGS_REQUIRE_GPU();
  CHUNGS_REQUIRE_DATA("kitti_seq1");
  const auto d = open_dataset("kitti:" + test::shared_data("kitti_seq1").string());
  const Frame f = d->frame(20);
  const Image8 l = to_gray(f.left), r = to_gray(*f.right);
  const SgmDisparities gpu = cuda::sgm_disparities(l, r, {}), cpu = sgm_disparities(l, r, {});
  EXPECT_EQ(differing(gpu.left, cpu.left), 0u);
  EXPECT_EQ(differing(gpu.right, cpu.right), 0u);
  StereoDepthConfig on_gpu;
  on_gpu.cuda = true;
  const StereoDepth a = stereo_depth(f.left, *f.right, f.camera.fx, f.baseline, on_gpu);
  const StereoDepth b = stereo_depth(f.left, *f.right, f.camera.fx, f.baseline);
  EXPECT_EQ(a.valid, b.valid);
  EXPECT_EQ(a.depth.vec(), b.depth.vec());
  EXPECT_GT(double(a.valid), 0.3 * double(l.pixels()));
}

TEST(CudaSgm, ThreadsTakeTurnsOnTheWorkspace) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(4);
  std::vector<std::pair<Image8, Image8>> pairs;
  for (int i = 0; i < 6; ++i) pairs.push_back(textured_pair(90 + 13 * i, 40 + 7 * i, 5 + i, rng));
  SgmParams p;
  p.disparities = 64;
  std::vector<SgmDisparities> got(pairs.size());
  std::vector<std::thread> threads;
  for (size_t i = 0; i < pairs.size(); ++i)
    threads.emplace_back([&, i] { got[i] = cuda::sgm_disparities(pairs[i].first, pairs[i].second, p); });
  for (auto& t : threads) t.join();
  for (size_t i = 0; i < pairs.size(); ++i) {
    const SgmDisparities cpu = sgm_disparities(pairs[i].first, pairs[i].second, p);
    EXPECT_EQ(differing(got[i].left, cpu.left), 0u) << i;
    EXPECT_EQ(differing(got[i].right, cpu.right), 0u) << i;
  }
}

}  // namespace
}  // namespace chungs
#endif
