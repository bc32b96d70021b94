// The depth refinement where the sampler uses it (issue 25, item 4): the sampler hands the refinement
// the drawn pixels that have measured depth (not fill depth, not seeds) and places the Gaussians, and
// chooses their chunks, at the depths it returns; refine_sampled_depths finds the neighbours among the
// mapper's earlier keyframes and their images in the keyframe store.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <utility>

#include "chungs/common/error.hpp"
#include "chungs/mapping/sample_refine.hpp"
#include "chungs/mapping/sampler.hpp"
#include "depth/sweep_scene.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

TEST(SamplerRefine, GaussiansSitAtTheRefinedDepthsAndOnlyMeasuredPixelsAreAsked) {
  const Camera cam(80, 60, 60, 60, 39.5, 29.5);
  const SE3 pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY())), Eigen::Vector3d(0.5, 0, 1));
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> U(0, 1);
  ImageF image(80, 60, 3);
  for (auto& v : image.vec()) v = float(U(rng));
  ImageF probability(80, 60, 1, 0.5f);
  ImageF depth(80, 60, 1, 0.0f);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 40; ++x) depth(x, y) = float(2 + 4 * U(rng));  // the right half has none
  const std::vector<Eigen::Vector3d> seeds{pose * cam.unproject(Eigen::Vector2d(60, 30), 3.0)};
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 0;
  c.min_per_chunk_floor = 0;
  c.fill_depth = 30;
  // Even columns move 25 % further, odd ones come back without depth (they keep the measured one).
  std::set<std::pair<int, int>> asked;
  size_t calls = 0;
  const RefineDepths refine = [&](std::vector<PixelDepth>& px) {
    ++calls;
    for (PixelDepth& p : px) {
      EXPECT_TRUE(asked.insert({p.x, p.y}).second) << "asked twice: " << p.x << "," << p.y;
      EXPECT_LT(p.x, 40) << "a pixel without measured depth was asked";
      EXPECT_EQ(p.depth, depth(p.x, p.y));
      p.depth = p.x % 2 == 0 ? 1.25f * p.depth : -1.0f;
    }
  };
  std::mt19937_64 draws(4);
  SampleStats st;
  const auto batches = sample_gaussians(c, image, depth, probability, cam, pose, 1.0, 3, 0, draws, &st, nullptr, 0,
                                        &seeds, &refine);
  EXPECT_EQ(calls, 1u);
  EXPECT_EQ(asked.size(), st.candidates - st.no_depth);
  EXPECT_GT(asked.size(), 500u);
  const SE3 T_cw = pose.inverse();
  size_t n = 0, seeds_seen = 0, filled = 0;
  for (const auto& b : batches)
    for (size_t i = 0; i < b.block.size(); ++i, ++n) {
      const auto& q = b.block.params;
      const Eigen::Vector3d X(q.mean[3 * i], q.mean[3 * i + 1], q.mean[3 * i + 2]);
      EXPECT_EQ(chunk_id_of(X, 1.0), b.id) << "a Gaussian in the chunk of its unrefined point";
      const Eigen::Vector3d pc = T_cw * X;
      const Eigen::Vector2d uv = cam.project(pc);
      const int x = int(std::lround(uv.x())), y = int(std::lround(uv.y()));
      if ((X - seeds[0]).norm() < 1e-5) {
        ++seeds_seen;
        continue;
      }
      if (x >= 40) {
        EXPECT_NEAR(pc.z(), 30.0, 1e-3);
        ++filled;
        continue;
      }
      const double want = x % 2 == 0 ? 1.25 * depth(x, y) : depth(x, y);
      EXPECT_NEAR(pc.z(), want, 1e-4 * want) << x << "," << y;
    }
  EXPECT_EQ(n, st.kept);
  EXPECT_EQ(seeds_seen, 1u);
  EXPECT_EQ(filled, st.no_depth);
  EXPECT_GT(filled, 0u);

  // Exclusion judges the refined point: excluding the chunks that only refined points reach drops them.
  std::unordered_set<ChunkId> far_chunks;
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 40; x += 2) {
      const ChunkId moved = chunk_id_of(pose * cam.unproject(Eigen::Vector2d(x, y), 1.25 * depth(x, y)), 1.0);
      if (moved != chunk_id_of(pose * cam.unproject(Eigen::Vector2d(x, y), depth(x, y)), 1.0)) far_chunks.insert(moved);
    }
  ASSERT_FALSE(far_chunks.empty());
  asked.clear();
  std::mt19937_64 again(4);
  SampleStats ex;
  const auto kept = sample_gaussians(c, image, depth, probability, cam, pose, 1.0, 3, 0, again, &ex, &far_chunks, 0,
                                     &seeds, &refine);
  for (const auto& b : kept) EXPECT_EQ(far_chunks.count(b.id), 0u);
  EXPECT_GT(ex.excluded, 0u);
  EXPECT_EQ(ex.kept + ex.excluded, st.kept);
}

// The sweep scene's views as earlier keyframes of a store, the reference view stored as keyframe
// `sampled` (the one being sampled, not yet in the records), and a sweep set for the scene.
struct StoredViews {
  test::SweepViews v;
  test::TempDir dir;
  KeyframeStore store{dir.path()};
  std::vector<KeyframeRecord> records;
  MultiviewDepthConfig c;

  explicit StoredViews(uint64_t sampled) {
    for (size_t i = 0; i < v.images.size(); ++i) {
      KeyframeRecord r;
      r.id = uint32_t(i), r.camera = v.scene.camera, r.pose = v.poses[i];
      records.push_back(r);
      store.put(i, KeyframeImages{v.images[i], ImageF()});
    }
    store.put(sampled, KeyframeImages{v.ref, ImageF()});
    c.sweep.max_rel_per_px = 0.5;  // the scene's short baselines (plane_sweep_test.cpp)
    c.sweep.best_k = 2;
    c.choice.min_overlap = 0.2;
  }
  // Pixels of the reference view on a grid from `first` to `end` in steps of `step`, with the true
  // inverse depth off by up to `noise`.
  std::vector<PixelDepth> noisy_pixels(int first, int step, int end_x, int end_y, double noise, unsigned seed) const {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(-noise, noise);
    std::vector<PixelDepth> px;
    for (int y = first; y < end_y; y += step)
      for (int x = first; x < end_x; x += step)
        if (v.gt(x, y) > 0) px.push_back({x, y, float(1.0 / (1.0 / v.gt(x, y) + U(rng)))});
    return px;
  }
};

TEST(SampleRefine, PolishesAgainstTheEarlierKeyframesOfTheStore) {
  StoredViews sv(7);
  const test::SweepViews& v = sv.v;
  const std::vector<KeyframeRecord>& records = sv.records;
  KeyframeStore& store = sv.store;
  const MultiviewDepthConfig& c = sv.c;
  std::vector<PixelDepth> px = sv.noisy_pixels(10, 5, 100, 110, 0.035, 2);
  const std::vector<PixelDepth> before = px;
  SampleRefineTotals totals;
  refine_sampled_depths(v.scene.camera, SE3(), 7, records, store, c, 0.05, false, px, totals);
  EXPECT_EQ(totals.samplings, 1u);
  EXPECT_EQ(totals.without_neighbour, 0u);
  EXPECT_EQ(totals.asked, px.size());
  EXPECT_GT(double(totals.refined), 0.5 * double(px.size()));
  double e0 = 0, e1 = 0;
  for (size_t i = 0; i < px.size(); ++i) {
    const double t = 1.0 / v.gt(px[i].x, px[i].y);
    e0 += std::abs(1.0 / before[i].depth - t), e1 += std::abs(1.0 / px[i].depth - t);
  }
  EXPECT_LT(e1, 0.5 * e0) << "mean inverse-depth error " << e0 / double(px.size()) << " -> " << e1 / double(px.size());

  // No earlier keyframe (only the one sampled itself): counted, and the depths stay.
  std::vector<KeyframeRecord> alone(1);
  alone[0].id = 7, alone[0].camera = v.scene.camera;
  std::vector<PixelDepth> kept = before;
  refine_sampled_depths(v.scene.camera, SE3(), 7, alone, store, c, 0.05, false, kept, totals);
  EXPECT_EQ(totals.samplings, 2u);
  EXPECT_EQ(totals.without_neighbour, 1u);
  for (size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(kept[i].depth, before[i].depth);
}

#ifdef CHUNGS_WITH_CUDA
// Under --device cuda the mapper's refinement runs the sweep's kernel: the same depths as the host's.
TEST(SampleRefine, TheGpuPathRefinesToTheSameDepths) {
  CHUNGS_REQUIRE_GPU();
  StoredViews sv(9);
  const test::SweepViews& v = sv.v;
  const std::vector<KeyframeRecord>& records = sv.records;
  KeyframeStore& store = sv.store;
  const MultiviewDepthConfig& c = sv.c;
  const std::vector<PixelDepth> px = sv.noisy_pixels(8, 3, 152, 112, 0.04, 6);
  std::vector<PixelDepth> host = px, gpu = px;
  SampleRefineTotals th, tg;
  refine_sampled_depths(v.scene.camera, SE3(), 9, records, store, c, 0.05, false, host, th);
  refine_sampled_depths(v.scene.camera, SE3(), 9, records, store, c, 0.05, true, gpu, tg);
  EXPECT_EQ(th.refined, tg.refined);
  EXPECT_GT(th.refined, px.size() / 2);
  for (size_t i = 0; i < px.size(); ++i) EXPECT_EQ(host[i].depth, gpu[i].depth) << i;
}
#endif

TEST(SampleRefine, ConfigRangesAreCheckedByName) {
  MultiviewDepthConfig c;
  EXPECT_TRUE(c.refine);  // on by default: bench/README.md (issue 25) has the measurements
  EXPECT_EQ(c.refine_rgbd_range, 0.05);
  EXPECT_EQ(c.refine_stereo_range, 0.01);
  c.validate();
  for (double bad : {0.0, -0.05, 11.0, std::nan("")}) {
    MultiviewDepthConfig r = c;
    r.refine_rgbd_range = bad;
    EXPECT_THROW(r.validate(), Error) << bad;
    MultiviewDepthConfig s = c;
    s.refine_stereo_range = bad;
    try {
      s.validate();
      ADD_FAILURE() << "refine_stereo_range " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("refine_stereo_range"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace chungs
