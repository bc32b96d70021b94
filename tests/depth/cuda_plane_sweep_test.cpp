// The plane sweep on the GPU against its CPU twin, bit for bit: dense and at sampled pixels, with and
// without a prior, over random poses, patch sizes and neighbour counts; and the refinement of measured
// depth, which runs the same kernel with an absolute band.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/depth/depth_refine.hpp"
#include "chungs/depth/plane_sweep.hpp"
#include "sweep_scene.hpp"

namespace chungs {
namespace {

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

size_t differing(const ImageF& a, const ImageF& b) {
  if (!a.same_shape(b)) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += !same_bits(a.vec()[i], b.vec()[i]);
  return n;
}

TEST(CudaPlaneSweep, MatchesTheCpuTwinBitForBit) {
  CHUNGS_REQUIRE_GPU();
  const test::SweepScene scene = test::wall_box_scene();
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> U(-0.4, 0.4);
  Image8 ref;
  ImageF gt, unused;
  scene.render(SE3(), ref, gt, 1.5, 1);
  for (int round = 0; round < 4; ++round) {
    const int views = 1 + round * 2;  // 1, 3, 5, 7 neighbours
    std::vector<Image8> images(static_cast<size_t>(views));
    std::vector<SE3> poses;
    for (int i = 0; i < views; ++i) {
      const Eigen::Quaterniond q(Eigen::AngleAxisd(0.05 * U(rng), Eigen::Vector3d(U(rng), 1, U(rng)).normalized()));
      poses.push_back(SE3(q, Eigen::Vector3d(U(rng), U(rng), 0.5 * U(rng) + 0.2)));
      scene.render(poses.back(), images[size_t(i)], unused, 2.0, unsigned(10 * round + i));
    }
    PlaneSweepInput in;
    in.camera = scene.camera;
    in.reference = {&ref, SE3()};
    for (int i = 0; i < views; ++i) in.neighbours.push_back({&images[size_t(i)], poses[size_t(i)]});
    // A prior on part of the image (confidence varying across the threshold), none elsewhere.
    ImageF prior(160, 120, 1, 0.0f), conf(160, 120, 1, 0.0f);
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x)
        if (gt(x, y) > 0 && (x / 20 + y / 20 + round) % 3 != 0) {
          prior(x, y) = float((1 + 0.1 * std::sin(0.1 * x)) / gt(x, y));
          conf(x, y) = float((x % 10) / 9.0);
        }
    PlaneSweepConfig c;
    c.patch_radius = 1 + round % 3;
    c.best_k = 1 + round % 2;
    c.near = 1.0, c.far = 20.0 + round;
    c.step_px = 0.7 + 0.3 * round;
    for (bool with_prior : {false, true}) {
      in.prior_inv_depth = with_prior ? &prior : nullptr;
      in.prior_confidence = with_prior ? &conf : nullptr;
      PlaneSweepConfig g = c;
      g.cuda = true;
      const PlaneSweepDepth cpu = plane_sweep_dense(in, c), gpu = plane_sweep_dense(in, g);
      EXPECT_EQ(differing(cpu.depth, gpu.depth), 0u) << "round " << round << " prior " << with_prior;
      EXPECT_EQ(differing(cpu.confidence, gpu.confidence), 0u) << "round " << round << " prior " << with_prior;
      EXPECT_EQ(cpu.valid, gpu.valid);
      EXPECT_GT(cpu.valid, 1000u);  // the comparison covers real matches, not only zeros
      std::vector<SweepPixel> px;
      for (int i = 0; i < 500; ++i) px.push_back({int(rng() % 160), int(rng() % 120)});
      const auto a = plane_sweep_at(in, px, c), b = plane_sweep_at(in, px, g);
      ASSERT_EQ(a.size(), b.size());
      for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_TRUE(same_bits(a[i].depth, b[i].depth)) << i << ": " << a[i].depth << " vs " << b[i].depth;
        EXPECT_TRUE(same_bits(a[i].confidence, b[i].confidence)) << i;
        EXPECT_TRUE(same_bits(a[i].depth, cpu.depth(px[i].x, px[i].y))) << i;
      }
    }
  }
}

// The refinement of measured depth (depth_refine.hpp) runs the same kernel with an absolute band:
// random measurements, bands and poses give the same refined depths on both, bit for bit.
TEST(CudaPlaneSweep, DepthRefinementMatchesTheCpuTwinBitForBit) {
  CHUNGS_REQUIRE_GPU();
  const test::SweepScene scene = test::wall_box_scene();
  std::mt19937 rng(33);
  std::uniform_real_distribution<double> U(-0.4, 0.4), S(-1, 1);
  Image8 ref;
  ImageF gt, unused;
  scene.render(SE3(), ref, gt, 1.5, 1);
  for (int round = 0; round < 4; ++round) {
    const int views = 2 + round;
    std::vector<Image8> images(static_cast<size_t>(views));
    std::vector<SE3> poses;
    for (int i = 0; i < views; ++i) {
      poses.push_back(SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(U(rng), U(rng), 0.5 * U(rng) + 0.2)));
      scene.render(poses.back(), images[size_t(i)], unused, 2.0, unsigned(40 * round + i));
    }
    PlaneSweepInput in;
    in.camera = scene.camera;
    in.reference = {&ref, SE3()};
    for (int i = 0; i < views; ++i) in.neighbours.push_back({&images[size_t(i)], poses[size_t(i)]});
    const double range = round % 2 ? 0.01 : 0.05;
    std::vector<PixelDepth> px;
    ImageF used(160, 120, 1, 0.0f);
    for (int i = 0; i < 1500; ++i) {
      const int x = int(rng() % 160), y = int(rng() % 120);
      if (used(x, y) != 0 || gt(x, y) <= 0) continue;
      used(x, y) = 1;
      px.push_back({x, y, float(1.0 / (1.0 / gt(x, y) + 0.8 * range * S(rng)))});
    }
    PlaneSweepConfig c;
    c.max_rel_per_px = 0.5;
    c.best_k = 1 + round % 2;
    PlaneSweepConfig g = c;
    g.cuda = true;
    std::vector<PixelDepth> a = px, b = px;
    const DepthRefineStats sa = refine_depths(in, a, range, c), sb = refine_depths(in, b, range, g);
    EXPECT_EQ(sa.refined, sb.refined);
    // Real matches, not only kept depths. The stereo band (0.01 1/m) moves a depth of ~1.5 m by ~2 %, so
    // far fewer pixels pass the cost-ratio test there than in the RGB-D band (H100: 56-106 of ~1,440).
    EXPECT_GT(sa.refined, px.size() / (range < 0.02 ? 40 : 4)) << "round " << round;
    for (size_t i = 0; i < px.size(); ++i)
      EXPECT_TRUE(same_bits(a[i].depth, b[i].depth)) << "round " << round << " pixel " << i << ": " << a[i].depth
                                                     << " vs " << b[i].depth;
  }
}

TEST(CudaPlaneSweep, EmptyPixelListAndBadPixelsOnTheGpuPath) {
  CHUNGS_REQUIRE_GPU();
  const test::SweepScene scene = test::wall_box_scene();
  Image8 ref, nb;
  ImageF gt;
  scene.render(SE3(), ref, gt, 1.0, 1);
  scene.render(test::translated(0.3, 0, 0), nb, gt, 1.0, 2);
  PlaneSweepInput in;
  in.camera = scene.camera;
  in.reference = {&ref, SE3()};
  in.neighbours.push_back({&nb, test::translated(0.3, 0, 0)});
  PlaneSweepConfig g;
  g.cuda = true;
  EXPECT_TRUE(plane_sweep_at(in, {}, g).empty());
  EXPECT_THROW(plane_sweep_at(in, {{0, 0}, {-1, 3}}, g), Error);
}

}  // namespace
}  // namespace chungs
#endif
