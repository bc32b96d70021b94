// Loop correction on a chunked map held by a Residency: every Gaussian of a moved keyframe moves
// exactly once (checked against a float64 reference), ends in the chunk of its new position, and
// none is lost or duplicated, in batch mode and chunk by chunk under a small budget.
#include "chungs/mapping/loop_corrector.hpp"

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "chungs/common/log.hpp"
#include "chungs/render/sh.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

constexpr double kChunk = 1.0;

SE3 random_delta(std::mt19937_64& rng, double max_angle, double max_shift) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  axis.normalize();
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(max_angle * u(rng), axis)),
             Eigen::Vector3d(max_shift * u(rng), max_shift * u(rng), max_shift * u(rng)));
}

// Colour channel c of SH coefficients (sh[3k + c], degree 3) seen along unit direction d, float64.
double colour(const float* sh, const Eigen::Vector3d& d, int c) {
  double b[kShCoeffs];
  sh::basis<double>(3, d.x(), d.y(), d.z(), b);
  double v = 0;
  for (int k = 0; k < kShCoeffs; ++k) v += b[k] * double(sh[3 * k + c]);
  return v;
}

Eigen::Vector3d random_direction(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// n Gaussians in a 6 x 5 x 2 m box; created_at_step tags each one uniquely.
GaussianBlock random_gaussians(size_t n, uint32_t keyframes, std::mt19937_64& rng) {
  GaussianBlock b;
  b.resize(n);
  std::uniform_real_distribution<float> u(0, 1), s(-1, 1);
  for (size_t i = 0; i < n; ++i) {
    b.params.mean[3 * i] = 6 * u(rng) - 3;
    b.params.mean[3 * i + 1] = 5 * u(rng) - 2.5f;
    b.params.mean[3 * i + 2] = 2 * u(rng);
    for (int a = 0; a < 3; ++a) b.params.log_scale[3 * i + a] = -3 + s(rng);
    for (int a = 0; a < 4; ++a) b.params.rotation[4 * i + a] = s(rng) + (a == 0 ? 1.5f : 0.f);
    b.params.opacity[i] = 2 * s(rng);
    for (int k = 0; k < kShFloats; ++k) b.params.sh[kShFloats * i + k] = 0.3f * s(rng);
    for (GaussianParams* m : {&b.adam_m, &b.adam_v})
      for (size_t k = 0; k < 3; ++k) m->mean[3 * i + k] = 0.01f * (1 + u(rng));
    b.adam_v.opacity[i] = 0.5f;
    b.adam_steps[i] = 7 + uint32_t(i % 5);
    b.lr_position_factor[i] = 0.5f;
    b.created_by_keyframe[i] = uint32_t(rng() % keyframes);
    b.created_at_step[i] = uint32_t(i);
  }
  return b;
}

// A map folder with the Gaussians filed by chunk, and the index the mapper would have built.
struct TestMap {
  test::TempDir dir;
  std::unique_ptr<ChunkStore> store;
  std::unique_ptr<CpuGaussianPool> pool;
  std::unique_ptr<Residency> residency;
  KeyframeChunkIndex index;

  TestMap(const GaussianBlock& all, size_t budget) {
    ChunkStoreConfig sc;
    sc.half_moments = sc.half_sh_rest = false;  // these tests compare exact round trips
    sc.chunk_size = kChunk;
    sc.durable = false;
    store = std::make_unique<ChunkStore>(dir.path(), sc);
    pool = std::make_unique<CpuGaussianPool>(budget);
    ResidencyConfig rc;
    rc.budget_gaussians = budget;
    residency = std::make_unique<Residency>(*store, *pool, rc);
    std::map<ChunkId, GaussianBlock> by_chunk;
    for (size_t i = 0; i < all.size(); ++i) {
      const float* m = &all.params.mean[3 * i];
      const ChunkId c = chunk_id_of(Eigen::Vector3d(m[0], m[1], m[2]), kChunk);
      by_chunk[c].append(all, i);
      index.add(all.created_by_keyframe[i], c);
    }
    for (auto& [c, b] : by_chunk) EXPECT_TRUE(residency->add(c, b).ok);
    residency->flush();
    residency->evict_all_unpinned();
  }

  std::vector<ChunkId> chunks() const {
    std::vector<ChunkId> v;
    for (const auto& [c, n] : residency->catalogue()) v.push_back(c);
    return v;
  }
};

struct Found {
  ChunkId chunk;
  GaussianBlock g;  // one Gaussian
};

// Every Gaussian on disk by tag; fails the test on a duplicate tag or a wrongly filed Gaussian.
std::map<uint32_t, Found> read_back(ChunkStore& store) {
  std::map<uint32_t, Found> out;
  for (ChunkId c : store.ids()) {
    const GaussianBlock b = store.load(c);
    for (size_t i = 0; i < b.size(); ++i) {
      const float* m = &b.params.mean[3 * i];
      EXPECT_EQ(chunk_id_of(Eigen::Vector3d(m[0], m[1], m[2]), kChunk), c)
          << "Gaussian " << b.created_at_step[i] << " filed in the wrong chunk";
      Found f{c, {}};
      f.g.append(b, i);
      EXPECT_TRUE(out.emplace(b.created_at_step[i], std::move(f)).second)
          << "Gaussian " << b.created_at_step[i] << " is stored twice";
    }
  }
  return out;
}

// Runs one correction and checks every Gaussian against the float64 reference.
PoseCorrectionStats check_correction(size_t budget, bool allow_batch, uint64_t seed) {
  std::mt19937_64 rng(seed);
  const uint32_t keyframes = 10;
  const GaussianBlock all = random_gaussians(3000, keyframes, rng);
  TestMap map(all, budget);
  PoseCorrection pc;
  for (uint32_t k = 0; k < 6; ++k) pc.delta[k] = random_delta(rng, 0.3, 1.5);
  pc.junction = {5, 8};
  pc.reset_opacity_logit = -2.5f;
  pc.allow_batch = allow_batch;
  std::vector<uint32_t> involved = {0, 1, 2, 3, 4, 5, 8};
  const auto candidates = map.index.chunks_of(involved);
  const PoseCorrectionStats st = apply_pose_correction(*map.residency, kChunk, pc, candidates, map.index);
  EXPECT_LE(map.residency->resident_gaussians(), budget);
  map.residency->flush();
  const auto found = read_back(*map.store);
  EXPECT_EQ(found.size(), all.size());
  size_t moved = 0, junction = 0, changed = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    const auto it = found.find(uint32_t(i));
    if (it == found.end()) {
      ADD_FAILURE() << "Gaussian " << i << " was lost";
      continue;
    }
    const GaussianBlock& g = it->second.g;
    const uint32_t kf = all.created_by_keyframe[i];
    Eigen::Vector3d p(all.params.mean[3 * i], all.params.mean[3 * i + 1], all.params.mean[3 * i + 2]);
    const float* r0 = &all.params.rotation[4 * i];
    Eigen::Quaterniond q(r0[0], r0[1], r0[2], r0[3]);
    const auto d = pc.delta.find(kf);
    if (d != pc.delta.end()) {
      p = d->second.rotation() * p + d->second.t;
      q = d->second.q * q;  // Hamilton product in float64
      ++moved;
    }
    const Eigen::Vector3d orig(all.params.mean[3 * i], all.params.mean[3 * i + 1],
                               all.params.mean[3 * i + 2]);
    if (chunk_id_of(orig, kChunk) != it->second.chunk) ++changed;
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(g.params.mean[a], p[a], 2e-5) << "mean of Gaussian " << i;
    const double qe[4] = {q.w(), q.x(), q.y(), q.z()};
    for (int a = 0; a < 4; ++a)
      EXPECT_NEAR(g.params.rotation[a], qe[a], 2e-5) << "rotation of Gaussian " << i;
    for (int a = 0; a < 3; ++a) EXPECT_EQ(g.params.log_scale[a], all.params.log_scale[3 * i + a]);
    const float* sh0 = &all.params.sh[kShFloats * i];
    for (int k = 0; k < 3; ++k) EXPECT_EQ(g.params.sh[k], sh0[k]);  // DC
    if (d != pc.delta.end()) {
      // The colour the Gaussian showed along d it now shows along R d.
      const Eigen::Vector3d dir = random_direction(rng), rotated = d->second.rotation() * dir;
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(colour(g.params.sh.data(), rotated, c), colour(sh0, dir, c), 1e-5);
    } else {
      for (int k = 3; k < kShFloats; ++k) EXPECT_EQ(g.params.sh[k], sh0[k]);
    }
    if (pc.junction.count(kf)) {
      ++junction;
      EXPECT_EQ(g.params.opacity[0], -2.5f);
      EXPECT_EQ(g.adam_steps[0], 0u);
      EXPECT_EQ(g.adam_m.mean[0], 0.f);
      EXPECT_EQ(g.adam_v.opacity[0], 0.f);
    } else {
      EXPECT_EQ(g.params.opacity[0], all.params.opacity[i]);
      EXPECT_EQ(g.adam_steps[0], all.adam_steps[i]);
      EXPECT_EQ(g.adam_m.mean[0], all.adam_m.mean[3 * i]);
    }
    // The index still finds it, so a second correction would too.
    const auto listed = map.index.chunks_of(std::vector<uint32_t>{kf});
    EXPECT_TRUE(std::binary_search(listed.begin(), listed.end(), it->second.chunk))
        << "index misses Gaussian " << i << " of keyframe " << kf;
  }
  EXPECT_EQ(st.gaussians_moved, moved);
  EXPECT_EQ(st.junction_gaussians, junction);
  EXPECT_EQ(st.gaussians_changed_chunk, changed);
  EXPECT_GT(changed, 300u);  // the test exercises moves between chunks
  EXPECT_GT(st.chunks_created, 0u);
  // Catalogue and store agree chunk by chunk.
  uint64_t total = 0;
  for (const auto& [c, n] : map.store->counts()) {
    EXPECT_EQ(map.residency->count(c), n);
    total += n;
  }
  EXPECT_EQ(total, all.size());
  return st;
}

TEST(LoopCorrector, TransformMatchesFloat64Reference) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int t = 0; t < 200; ++t) {
    const SE3 d = random_delta(rng, 3.0, 20.0);
    float mean[3] = {float(10 * u(rng)), float(10 * u(rng)), float(10 * u(rng))};
    float rot[4] = {float(u(rng)), float(u(rng)), float(u(rng)), float(u(rng) + 0.1)};
    const Eigen::Vector3d p(mean[0], mean[1], mean[2]);
    const Eigen::Quaterniond q(rot[0], rot[1], rot[2], rot[3]);
    transform_gaussian(d, mean, rot);
    const Eigen::Vector3d pe = d.rotation() * p + d.t;
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(mean[a], pe[a], 1e-5 * (1 + std::abs(pe[a])));
    // The rotation matrix of the result is R_delta R_q, and the stored norm is kept.
    const Eigen::Quaterniond r(rot[0], rot[1], rot[2], rot[3]);
    EXPECT_NEAR(r.norm(), q.norm(), 1e-5);
    const Eigen::Matrix3d re = d.rotation() * q.normalized().toRotationMatrix();
    EXPECT_LT((r.normalized().toRotationMatrix() - re).cwiseAbs().maxCoeff(), 1e-5);
  }
}

TEST(LoopCorrector, ShRotationKeepsTheColourSeenFromTheMovedCamera) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int t = 0; t < 50; ++t) {
    const Eigen::Matrix3d R = random_delta(rng, 3.0, 0).rotation();
    float sh[kShFloats];
    for (float& v : sh) v = u(rng);
    float out[kShFloats];
    std::copy(sh, sh + kShFloats, out);
    rotate_sh(sh_rotation(R), 3, out);
    for (int j = 0; j < 10; ++j) {
      const Eigen::Vector3d d = random_direction(rng);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(colour(out, R * d, c), colour(sh, d, c), 1e-5);
    }
    // Degree 1 rotates only band 1.
    std::copy(sh, sh + kShFloats, out);
    rotate_sh(sh_rotation(R), 1, out);
    for (int k = 4 * 3; k < kShFloats; ++k) EXPECT_EQ(out[k], sh[k]);
    EXPECT_GT(std::abs(out[3] - sh[3]) + std::abs(out[6] - sh[6]) + std::abs(out[9] - sh[9]), 1e-4);
  }
}

TEST(LoopCorrector, BatchModeFilesEveryGaussianOnceInItsNewChunk) {
  log::set_level(log::Level::Warn);
  const auto st = check_correction(20000, true, 11);
  EXPECT_TRUE(st.batch);
}

TEST(LoopCorrector, SmallBudgetVisitsChunkByChunkAndFilesEveryGaussianOnce) {
  log::set_level(log::Level::Warn);
  // About a tenth of the map fits: the batch cannot, so chunks are visited one at a time.
  const auto st = check_correction(400, true, 12);
  EXPECT_FALSE(st.batch);
}

TEST(LoopCorrector, ChunkByChunkWhenBatchIsNotAllowed) {
  log::set_level(log::Level::Warn);
  const auto st = check_correction(20000, false, 13);
  EXPECT_FALSE(st.batch);
}

// A shift of exactly one chunk moves every Gaussian into a neighbour that the same keyframe also
// fills, often one not visited yet: each must still move once, not once per visit.
TEST(LoopCorrector, GaussianMovedIntoAChunkNotYetVisitedMovesOnce) {
  log::set_level(log::Level::Warn);
  for (bool batch : {true, false}) {
    std::mt19937_64 rng(5);
    GaussianBlock all = random_gaussians(1500, 1, rng);
    TestMap map(all, batch ? 10000 : 300);
    PoseCorrection pc;
    pc.allow_batch = batch;
    for (const Eigen::Vector3d& shift :
         {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 0, 1)}) {
      pc.delta = {{0u, SE3(Eigen::Quaterniond::Identity(), shift)}};
      const auto cand = map.index.chunks_of(std::vector<uint32_t>{0});
      const auto st = apply_pose_correction(*map.residency, kChunk, pc, cand, map.index);
      EXPECT_EQ(st.batch, batch);
      EXPECT_EQ(st.gaussians_moved, all.size());
      for (size_t i = 0; i < all.size(); ++i)
        for (int a = 0; a < 3; ++a) all.params.mean[3 * i + a] += float(shift[a]);
    }
    map.residency->flush();
    const auto found = read_back(*map.store);
    ASSERT_EQ(found.size(), all.size());
    for (const auto& [tag, f] : found)
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(f.g.params.mean[a], all.params.mean[3 * tag + a], 1e-5);
  }
}

TEST(LoopCorrector, IndexRoundTripsThroughJsonAndRejectsGarbage) {
  KeyframeChunkIndex idx;
  idx.add(3, chunk_id({1, -2, 3}));
  idx.add(3, chunk_id({1, -2, 3}));
  idx.add(7, chunk_id({-100, 0, 5}));
  idx.add(12, chunk_id({4, 5, -6}));
  idx.add(12, chunk_id({-4, 5, 6}));
  TextPieces pieces;
  idx.append_json(pieces);
  const std::string text = pieces.str();
  // Keyframes in numeric order (12 after 7), each list sorted: the text the tree would dump.
  const nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j.size(), 3u);
  EXPECT_EQ(j.at("12").size(), 2u);
  EXPECT_LT(text.find("\"7\""), text.find("\"12\""));
  const auto back = KeyframeChunkIndex::from_json(j);
  TextPieces again;
  back.append_json(again);
  EXPECT_EQ(again.str(), text);
  EXPECT_EQ(back.entries(), 4u);
  EXPECT_EQ(back.chunks_of(std::vector<uint32_t>{3, 7}).size(), 2u);
  EXPECT_EQ(back.chunks_of(std::vector<uint32_t>{12}),
            (std::vector<ChunkId>{std::min(chunk_id({4, 5, -6}), chunk_id({-4, 5, 6})),
                                  std::max(chunk_id({4, 5, -6}), chunk_id({-4, 5, 6}))}));
  TextPieces empty;
  KeyframeChunkIndex().append_json(empty);
  EXPECT_EQ(empty.str(), "{}");
  EXPECT_THROW(KeyframeChunkIndex::from_json(nlohmann::json{{"x1", {"10"}}}), Error);
  EXPECT_THROW(KeyframeChunkIndex::from_json(nlohmann::json{{"1", {"zz"}}}), Error);
  EXPECT_THROW(KeyframeChunkIndex::from_json(nlohmann::json::array()), Error);
}

}  // namespace
}  // namespace chungs
