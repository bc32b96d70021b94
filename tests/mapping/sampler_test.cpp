// LoG probability, sampling probability and placement of new Gaussians.
#include "chungs/mapping/sampler.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <unordered_set>

#include "chungs/common/error.hpp"
#include "chungs/mapping/log_probability.hpp"

namespace chungs {
namespace {

ImageF random_image(int w, int h, int ch, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(0, 1);
  ImageF img(w, h, ch);
  for (auto& v : img.vec()) v = U(rng);
  return img;
}

TEST(LogProbability, IsZeroOnFlatImagesAndPositiveAtEdges) {
  ImageF flat(40, 30, 3, 0.4f);
  const ImageF pf = log_probability(flat);
  for (float v : pf.vec()) EXPECT_EQ(v, 0.f);
  ImageF step(40, 30, 3, 0.1f);
  for (int y = 0; y < 30; ++y)
    for (int x = 20; x < 40; ++x)
      for (int c = 0; c < 3; ++c) step(x, y, c) = 0.9f;
  const ImageF p = log_probability(step);
  EXPECT_GT(p(20, 15), 0.05f);
  EXPECT_GT(p(19, 15), 0.05f);
  EXPECT_EQ(p(5, 15), 0.f);   // far from the edge
  EXPECT_EQ(p(35, 15), 0.f);
  const ImageF pr = log_probability(random_image(30, 20, 3, 1));
  for (float v : pr.vec()) {
    EXPECT_GE(v, 0.f);
    EXPECT_LE(v, 1.f);
  }
}

TEST(Sampler, ProbabilityIsScaledPositivePartOfTheDifference) {
  const ImageF a = random_image(32, 24, 3, 2), b = random_image(32, 24, 3, 3);
  ImageF alpha(32, 24, 1, 1.f);
  for (int x = 0; x < 32; ++x) alpha(x, 0) = 0.f;  // an empty row of the render
  SamplerConfig c;
  c.density = 1.5;
  c.empty_floor = 0.3;
  const ImageF pa = log_probability(a), pb = log_probability(b);
  const ImageF p = sampling_probability(c, a, &b, &alpha);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      double want = std::min(1.0, 1.5 * std::max(0.0, double(pa(x, y)) - double(pb(x, y))));
      if (y == 0) want = std::max(want, 0.3);
      EXPECT_NEAR(p(x, y), want, 1e-6) << x << "," << y;
    }
}

TEST(Sampler, AcceptanceRateFollowsTheProbability) {
  ImageF img(100, 100, 3, 0.5f), depth(100, 100, 1, 2.f), prob(100, 100, 1, 0.f);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 50; ++x) prob(x, y) = 0.3f;  // right half: never
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 0;
  c.min_per_chunk_floor = 0;
  std::mt19937_64 rng(7);
  SampleStats st;
  const Camera cam(100, 100, 80, 80, 49.5, 49.5);
  auto batches = sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &st);
  EXPECT_NEAR(double(st.kept) / 5000.0, 0.3, 0.03);
  for (const auto& b : batches)
    for (size_t i = 0; i < b.block.size(); ++i) EXPECT_LT(b.block.params.mean[3 * i], 0.0 + 1e-6);
}

TEST(Sampler, SameSeedSameGaussiansWhateverTheThreadsDo) {
  // The draws run on several threads in bands of rows: the result must not depend on their timing.
  const Camera cam(200, 150, 160, 160, 99.5, 74.5);
  std::mt19937 r(3);
  std::uniform_real_distribution<float> U(0.f, 1.f);
  ImageF img = random_image(200, 150, 3, 4), depth(200, 150, 1), prob(200, 150, 1);
  for (auto& d : depth.vec()) d = 1.f + 40.f * U(r);
  for (auto& p : prob.vec()) p = 0.5f * U(r);
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 0;
  c.min_per_chunk_floor = 0;
  auto run = [&](uint64_t seed) {
    std::mt19937_64 rng(seed);
    SampleStats st;
    auto batches = sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &st);
    std::vector<float> means;
    for (const auto& b : batches) means.insert(means.end(), b.block.params.mean.begin(), b.block.params.mean.end());
    return means;
  };
  const std::vector<float> a = run(11);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(run(11), a);
  EXPECT_NE(run(12), a);
  // The counter-based draws keep the acceptance rate: about half the pixels at p = 0.5.
  ImageF flat(200, 150, 1, 0.5f);
  std::mt19937_64 rng(5);
  SampleStats st;
  auto batches = sample_gaussians(c, img, depth, flat, cam, SE3(), 10.0, 0, 0, rng, &st);
  EXPECT_NEAR(double(st.candidates) / (200.0 * 150.0), 0.5, 0.02);
}

TEST(Sampler, PlacesGaussiansOnPixelRaysWithFootprintAndChunks) {
  const Camera cam(40, 30, 35, 36, 19.2, 14.7);
  const SE3 pose(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix(),
                 Eigen::Vector3d(3.1, -1.2, 0.4));
  std::mt19937 r(5);
  std::uniform_real_distribution<float> U(0.5f, 9.f);
  ImageF img = random_image(40, 30, 3, 9), depth(40, 30, 1), prob(40, 30, 1, 0.25f);
  for (auto& d : depth.vec()) d = U(r);
  // Every third pixel's depth is a guess (negated): placed at its magnitude all the same.
  for (size_t i = 0; i < depth.pixels(); i += 3) depth.vec()[i] = -depth.vec()[i];
  depth(3, 3) = 0;  // no depth: skipped
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 0;
  c.min_per_chunk_floor = 0;
  c.density = 1.0;
  std::mt19937_64 rng(1);
  prob(3, 3) = 1.f;
  SampleStats st;
  const double s = 2.0;
  auto batches = sample_gaussians(c, img, depth, prob, cam, pose, s, 4, 17, rng, &st);
  ASSERT_GT(st.kept, 100u);
  EXPECT_EQ(st.no_depth, 1u) << "a guessed depth is a depth";
  const SE3 inv = pose.inverse();
  for (const auto& b : batches)
    for (size_t i = 0; i < b.block.size(); ++i) {
      const Eigen::Vector3d pw(b.block.params.mean[3 * i], b.block.params.mean[3 * i + 1], b.block.params.mean[3 * i + 2]);
      EXPECT_EQ(chunk_id_of(pw, s), b.id);
      const Eigen::Vector3d pc = inv * pw;
      const Eigen::Vector2d px = cam.project(pc);
      const int x = int(std::lround(px.x())), y = int(std::lround(px.y()));
      ASSERT_NEAR(px.x(), x, 1e-3);
      ASSERT_NEAR(px.y(), y, 1e-3);
      EXPECT_NEAR(pc.z(), std::abs(depth(x, y)), 1e-4);
      // 1/sqrt(0.25) = 2 px wide at that depth.
      EXPECT_NEAR(std::exp(b.block.params.log_scale[3 * i]), 2.0 * pc.z() / cam.fx, 1e-4);
      EXPECT_NEAR(1 / (1 + std::exp(-b.block.params.opacity[i])), 0.07, 1e-6);
      EXPECT_NEAR(0.5 + 0.28209479 * b.block.params.sh[48 * i], img(x, y, 0), 1e-5);
      EXPECT_EQ(b.block.created_by_keyframe[i], 4u);
      EXPECT_EQ(b.block.created_at_step[i], 17u);
    }
}

// Beyond the far-level distance a view's Gaussians go into the far level of their cube (chunk_id.hpp),
// which is what the view will draw and train there.
TEST(Sampler, PointsBeyondTheFarLevelDistanceGoToTheFarLevelOfTheirCube) {
  const Camera cam(40, 30, 35, 36, 19.2, 14.7);
  const SE3 pose(Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.1, 1, 0.3).normalized()).toRotationMatrix(),
                 Eigen::Vector3d(-4.3, 0.8, 2.1));
  std::mt19937 r(8);
  std::uniform_real_distribution<float> U(2.f, 60.f);
  ImageF img = random_image(40, 30, 3, 4), depth(40, 30, 1), prob(40, 30, 1, 0.5f);
  for (auto& d : depth.vec()) d = U(r);
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 0;
  c.min_per_chunk_floor = 0;
  const double s = 5.0, far = 27.5;
  std::mt19937_64 rng(2);
  size_t near_n = 0, far_n = 0;
  for (const auto& b : sample_gaussians(c, img, depth, prob, cam, pose, ChunkGrid(s, far), 0, 0, rng))
    for (size_t i = 0; i < b.block.size(); ++i) {
      const Eigen::Vector3d pw(b.block.params.mean[3 * i], b.block.params.mean[3 * i + 1], b.block.params.mean[3 * i + 2]);
      const ChunkCoord cube = chunk_coord_of(pw, s);
      const double centre = (Eigen::Vector3d(cube.x * s, cube.y * s, cube.z * s) - pose.t).norm();
      ASSERT_EQ(near_level_of(b.id), chunk_id(cube));
      ASSERT_EQ(is_far_level(b.id), centre > far) << "cube centre at " << centre << " m";
      (is_far_level(b.id) ? far_n : near_n)++;
    }
  EXPECT_GT(near_n, 50u);
  EXPECT_GT(far_n, 50u);
}

TEST(Sampler, DropsChunksThatReceiveTooFewGaussians) {
  const Camera cam(60, 10, 50, 50, 29.5, 4.5);
  ImageF img(60, 10, 3, 0.5f), depth(60, 10, 1, 5.f), prob(60, 10, 1, 1.f);
  for (int y = 0; y < 10; ++y) depth(0, y) = 40.f;  // a far column: its own chunk, 10 points
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 20 * 1e5 / (60 * 10);  // 20 Gaussians on this image
  c.min_per_chunk_floor = 0;
  std::mt19937_64 rng(3);
  SampleStats st;
  auto batches = sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &st);
  EXPECT_EQ(st.dropped_small_chunks, 10u);
  for (const auto& b : batches) EXPECT_GE(b.block.size(), 20u);
  {
    // Asked for, the held-back picks come back built like the others: the far column's ten points.
    std::mt19937_64 same(3);
    std::vector<ChunkBatch> strays;
    SampleStats s2;
    const auto kept = sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 2, 9, same, &s2, nullptr, 0, nullptr,
                                       nullptr, nullptr, &strays);
    EXPECT_EQ(s2.kept, st.kept);
    EXPECT_EQ(kept.size(), batches.size());
    size_t n = 0;
    for (const auto& b : strays) {
      EXPECT_LT(b.block.size(), 20u);
      for (size_t i = 0; i < b.block.size(); ++i) {
        EXPECT_NEAR(b.block.params.mean[3 * i + 2], 40.f, 1e-3);  // the far column's depth
        EXPECT_EQ(b.block.created_by_keyframe[i], 2u);
        EXPECT_EQ(b.block.created_at_step[i], 9u);
      }
      n += b.block.size();
    }
    EXPECT_EQ(n, 10u);
  }
  // Once the far column's chunk holds Gaussians, its ten picks are kept: the rule is against new
  // chunks of a few stray points, not against a place that enters the view a few pixels at a time.
  std::unordered_set<ChunkId> established;
  for (int k = 0; k < 2; ++k) {
    std::mt19937_64 again(3);
    SampleStats with;
    auto kept = sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, again, &with, nullptr, 0, nullptr,
                                 nullptr, &established);
    if (k == 0) {  // nothing established: the same as without the set
      EXPECT_EQ(with.dropped_small_chunks, 10u);
      // Establish every chunk the column's points fall in: the unfiltered draw's chunks, found by a
      // run without the rule.
      SamplerConfig all = c;
      all.min_per_chunk_per_100k_px = 0;
      std::mt19937_64 r3(3);
      for (const auto& b : sample_gaussians(all, img, depth, prob, cam, SE3(), 10.0, 0, 0, r3)) established.insert(b.id);
      EXPECT_GT(established.size(), batches.size());
    } else {
      EXPECT_EQ(with.dropped_small_chunks, 0u);
      EXPECT_EQ(with.kept, st.kept + 10);
    }
  }
}

// The stray-chunk threshold follows the image size: the paper's 100 at KITTI's 1241x376, a quarter of it
// at half the width and height, so a quarter-size image does not leave whole chunks empty; but not below
// the floor, which keeps chunk files from holding a handful of Gaussians each.
TEST(Sampler, TheLeastPerChunkFollowsThePixelCountDownToAFloor) {
  SamplerConfig c;
  EXPECT_EQ(c.min_per_chunk(1241 * 376, 10), 100u);
  EXPECT_EQ(c.min_per_chunk(2 * 1241 * 376, 10), 200u);
  EXPECT_EQ(c.min_per_chunk(620 * 188, 10), 50u);  // 25 scaled, under the floor
  EXPECT_EQ(c.min_per_chunk(310 * 94, 10), 50u);
  // A chunk of 10 points in a 60x10 image: dropped at the default floor, kept without one.
  const Camera cam(60, 10, 50, 50, 29.5, 4.5);
  ImageF img(60, 10, 3, 0.5f), depth(60, 10, 1, 5.f), prob(60, 10, 1, 1.f);
  for (int y = 0; y < 10; ++y) depth(0, y) = 40.f;
  std::mt19937_64 rng(3);
  SampleStats st;
  sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &st);
  EXPECT_EQ(st.dropped_small_chunks, 10u);
  c.min_per_chunk_floor = 0;
  EXPECT_EQ(c.min_per_chunk(310 * 94, 10), 6u);
  sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &st);
  EXPECT_EQ(st.dropped_small_chunks, 0u);
  for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity(), 2e5}) {
    SamplerConfig b;
    b.min_per_chunk_per_100k_px = bad;
    EXPECT_THROW(b.validate(), std::exception) << bad;
  }
}


// The threshold's counts are for 10 m chunks and scale with a chunk's face area: chunks of 5 m need a
// quarter, the indoor preset's 2 m a twenty-fifth, 20 m four times as many; never below one.
TEST(Sampler, TheLeastPerChunkScalesWithTheChunksFaceArea) {
  SamplerConfig c;
  EXPECT_EQ(c.min_per_chunk(1241 * 376, 5), 25u);
  EXPECT_EQ(c.min_per_chunk(310 * 94, 5), 13u);  // the floor's 50 / 4 = 12.5, rounded
  EXPECT_EQ(c.min_per_chunk(1241 * 376, 2), 4u);
  EXPECT_EQ(c.min_per_chunk(1241 * 376, 20), 400u);
  EXPECT_EQ(c.min_per_chunk(310 * 94, 0.5), 1u);
  // Under 5 m chunks the sampler drops exactly the chunks under the scaled threshold (13 here), not
  // those under 10 m's (50): the chunks of an unthresholded draw say which those are.
  const Camera cam(60, 10, 50, 50, 29.5, 4.5);
  ImageF img(60, 10, 3, 0.5f), depth(60, 10, 1, 5.f), prob(60, 10, 1, 1.f);
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 10; ++y) depth(x, y) = 40.f;
  SamplerConfig all = c;
  all.min_per_chunk_floor = 0;
  all.min_per_chunk_per_100k_px = 0;
  std::mt19937_64 r0(3);
  uint64_t under_scaled = 0, under_unscaled = 0;
  for (const ChunkBatch& b : sample_gaussians(all, img, depth, prob, cam, SE3(), 5.0, 0, 0, r0)) {
    if (b.block.size() < c.min_per_chunk(60 * 10, 5.0)) under_scaled += b.block.size();
    if (b.block.size() < c.min_per_chunk(60 * 10, 10.0)) under_unscaled += b.block.size();
  }
  ASSERT_GT(under_scaled, 0u);
  ASSERT_GT(under_unscaled, under_scaled);  // the geometry tells the two thresholds apart
  std::mt19937_64 rng(3);
  SampleStats st;
  sample_gaussians(c, img, depth, prob, cam, SE3(), 5.0, 0, 0, rng, &st);
  EXPECT_EQ(st.dropped_small_chunks, under_scaled);
}

TEST(Sampler, SkipsPointsInExcludedChunksAndCapsTheRestEvenly) {
  // Left half at 5 m, right half at 25 m: two chunks of 10 m along the optical axis (a narrow view
  // keeps each half inside one chunk sideways).
  const Camera cam(80, 20, 600, 600, 39.5, 9.5);
  ImageF img = random_image(80, 20, 3, 4), depth(80, 20, 1, 5.f), prob(80, 20, 1, 1.f);
  for (int y = 0; y < 20; ++y)
    for (int x = 40; x < 80; ++x) depth(x, y) = 25.f;
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 50 * 1e5 / (80 * 20);  // 50 Gaussians on this image
  c.min_per_chunk_floor = 0;
  const ChunkId near = chunk_id_of(Eigen::Vector3d(0, 0, 5), 10.0), far = chunk_id_of(Eigen::Vector3d(0, 0, 25), 10.0);
  ASSERT_NE(near, far);
  std::mt19937_64 rng(11);
  SampleStats st;
  const std::unordered_set<ChunkId> exclude{far};
  auto batches = sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &st, &exclude);
  EXPECT_EQ(st.excluded, 800u);  // every pixel of the far half
  ASSERT_FALSE(batches.empty());
  for (const auto& b : batches) EXPECT_NE(b.id, far);
  // A cap of 300 thins both halves alike; neither chunk falls under the least per chunk and vanishes.
  SampleStats capped;
  auto thin = sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &capped, nullptr, 300);
  EXPECT_EQ(capped.kept, 300u);
  EXPECT_EQ(capped.capped, 1300u);
  ASSERT_EQ(thin.size(), 2u);
  for (const auto& b : thin) {
    EXPECT_GT(b.block.size(), 110u);
    EXPECT_LT(b.block.size(), 190u);
  }
  // config.max_per_keyframe caps as well, the smaller cap winning.
  c.max_per_keyframe = 120;
  SampleStats both;
  sample_gaussians(c, img, depth, prob, cam, SE3(), 10.0, 0, 0, rng, &both, nullptr, 300);
  EXPECT_EQ(both.kept, 120u);
}

TEST(Sampler, APointOutsideTheChunkIdRangeIsAnErrorOnTheCallersThread) {
  // Chunks of a nanometre put a point 6 m away at chunk 6e9, beyond the ids' 2^20 per axis: the
  // error was thrown inside the OpenMP region and ended the process (terminate called recursively).
  const Camera cam(64, 48, 50, 50, 31.5, 23.5);
  const ImageF img(64, 48, 3, 0.5f), depth(64, 48, 1, 6.f), prob(64, 48, 1, 1.f);
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 0;
  c.min_per_chunk_floor = 0;
  std::mt19937_64 rng(5);
  try {
    sample_gaussians(c, img, depth, prob, cam, SE3(), 1e-9, 0, 0, rng);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("outside the id range"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("chunk size 1e-09"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace chungs
