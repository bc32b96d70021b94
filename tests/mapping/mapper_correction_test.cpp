// Mapper::correct_poses end to end on a tiny RGB-D sequence: batch and chunk-by-chunk give the
// same map, the folder reopens with the new poses and the keyframe->chunk index, and a second
// correction after resuming undoes the first.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

Config tiny_config(size_t budget) {
  Config c = test::tiny_mapping_config();
  c.store.chunk_size = 0.5;
  c.sampler.min_per_chunk_per_100k_px = 5 * 1e5 / (64 * 48);  // 5 on the 64x48 wall
  c.sampler.min_per_chunk_floor = 0;
  c.prune.every = 0;  // counts must not change through pruning here
  c.residency.budget_gaussians = budget;
  return c;
}

// Maps `frames` keyframes of the wall with a few steps each and checkpoints.
void map_wall(const std::filesystem::path& folder, const Config& c, size_t frames) {
  const test::WallSequence seq(frames);
  Mapper m(folder, c, false);
  for (size_t i = 0; i < frames; ++i) {
    const Frame f = seq.frame(i);
    m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    for (int k = 0; k < 3; ++k) m.step();
  }
  m.checkpoint({});
}

// Every Gaussian of the folder, keyed by values that a correction leaves alone (keyframe, scales,
// colour, opacity) and mapped to (chunk, mean, rotation). Checks the filing of the Gaussians of
// keyframes >= check_from (the optimiser may carry others out of their chunk).
using Key = std::array<float, 8>;
using Value = std::array<double, 8>;
std::map<Key, Value> stored(const std::filesystem::path& folder, double chunk_size, uint32_t check_from) {
  ChunkStore store(folder);
  std::map<Key, Value> out;
  for (ChunkId c : store.ids()) {
    const GaussianBlock b = store.load(c);
    for (size_t i = 0; i < b.size(); ++i) {
      const float* m = &b.params.mean[3 * i];
      const float* r = &b.params.rotation[4 * i];
      const float* s = &b.params.log_scale[3 * i];
      const float* sh = &b.params.sh[size_t(kShFloats) * i];
      if (b.created_by_keyframe[i] >= check_from) {
        EXPECT_EQ(chunk_id_of(Eigen::Vector3d(m[0], m[1], m[2]), chunk_size), c)
            << "Gaussian in the wrong chunk";
      }
      const Key k{
          float(b.created_by_keyframe[i]), s[0], s[1], s[2], sh[0], sh[1], sh[2], b.params.opacity[i]};
      EXPECT_TRUE(out.emplace(k, Value{double(c), m[0], m[1], m[2], r[0], r[1], r[2], r[3]}).second)
          << "two Gaussians with the same key (or one stored twice)";
    }
  }
  return out;
}

std::vector<std::pair<uint32_t, SE3>> shifted(const Mapper& m, uint32_t first, const SE3& d) {
  std::vector<std::pair<uint32_t, SE3>> v;
  for (const auto& k : m.keyframes())
    if (k.id >= first) v.emplace_back(k.id, d * k.pose);
  return v;
}

const SE3 kDelta(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 1, 0.2).normalized())),
                 Eigen::Vector3d(0.7, -0.4, 0.3));

TEST(MapperCorrection, BatchAndChunkByChunkGiveTheSameMapAndResumeUndoes) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const Config c = tiny_config(200'000);
  map_wall(dir / "a", c, 8);
  std::filesystem::copy(dir / "a", dir / "b", std::filesystem::copy_options::recursive);
  const auto before = stored(dir / "a", c.store.chunk_size, UINT32_MAX);
  ASSERT_GT(before.size(), 1000u);

  // "a" corrects in one batch; "b" reopens with a budget of a fraction of the map (every keyframe
  // sees the whole wall, so the moved keyframes touch nearly every chunk) and goes chunk by chunk.
  const size_t small_budget = 800;
  PoseCorrectionStats sa, sb;
  for (const char* name : {"a", "b"}) {
    const bool batch = std::string(name) == "a";
    const Config cm = batch ? c : tiny_config(small_budget);
    Mapper m(dir / name, cm, true);
    const uint64_t total = m.total_gaussians();
    const PoseCorrectionStats s = m.correct_poses(shifted(m, 6, kDelta), {}, 0);
    (batch ? sa : sb) = s;
    EXPECT_EQ(m.total_gaussians(), total);
    EXPECT_LE(m.peak_resident_gaussians(), cm.residency.budget_gaussians);
    EXPECT_EQ(m.budget(), cm.residency.budget_gaussians);
    EXPECT_LT((m.keyframes()[7].pose.t - (kDelta * test::WallSequence(8).gt_pose(7).value()).t).norm(),
              1e-12);
    m.checkpoint({{"next_frame", 8}});
  }
  std::printf("%zu Gaussians, %zu moved (%zu to another chunk), %zu chunks touched, %zu new\n", before.size(),
              sa.gaussians_moved, sa.gaussians_changed_chunk, sa.chunks_touched, sa.chunks_created);
  EXPECT_TRUE(sa.batch);
  EXPECT_FALSE(sb.batch);
  EXPECT_EQ(sa.keyframes, 2u);
  EXPECT_GT(sa.gaussians_moved, 300u);
  EXPECT_GT(sa.gaussians_changed_chunk, 100u);
  EXPECT_EQ(sa.gaussians_moved, sb.gaussians_moved);
  EXPECT_EQ(sa.gaussians_changed_chunk, sb.gaussians_changed_chunk);
  const auto after_a = stored(dir / "a", c.store.chunk_size, 6),
             after_b = stored(dir / "b", c.store.chunk_size, 6);
  EXPECT_TRUE(after_a == after_b);  // bit-identical whichever way the chunks were visited
  ASSERT_EQ(after_a.size(), before.size());
  size_t moved = 0;
  for (const auto& [k, v] : after_a) {
    ASSERT_TRUE(before.count(k)) << "a Gaussian changed more than its pose";
    moved += k[0] >= 6;
  }
  EXPECT_EQ(moved, sa.gaussians_moved);

  // Reopened: the new poses are back, and the index finds the moved Gaussians again, so the
  // inverse correction restores the map (to float rounding).
  {
    Mapper m(dir / "a", c, true);
    EXPECT_LT((m.keyframes()[6].pose.t - (kDelta * test::WallSequence(8).gt_pose(6).value()).t).norm(), 1e-9);
    m.correct_poses(shifted(m, 6, kDelta.inverse()), {}, 0);
    m.checkpoint({});
  }
  const auto back = stored(dir / "a", c.store.chunk_size, 6);
  ASSERT_EQ(back.size(), before.size());
  double worst = 0;
  for (const auto& [k, v] : back) {
    const auto it = before.find(k);
    ASSERT_TRUE(it != before.end());
    for (int a = 1; a < 8; ++a) worst = std::max(worst, std::abs(v[a] - it->second[a]));
  }
  EXPECT_LT(worst, 1e-5);
}

// The pool holds pool_headroom beyond the budget, so a correction whose chunks exceed the budget
// but fit the pool still runs in one batch (the budget is raised for it, then restored); without
// headroom the same correction goes chunk by chunk. Both move the same Gaussians.
TEST(MapperCorrection, PoolHeadroomLetsALargerCorrectionRunInOneBatch) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const Config c = tiny_config(200'000);
  map_wall(dir / "a", c, 6);
  std::filesystem::copy(dir / "a", dir / "b", std::filesystem::copy_options::recursive);
  uint64_t total = 0;
  {
    Mapper m(dir / "a", c, true);
    total = m.total_gaussians();
  }
  ASSERT_GT(total, 500u);
  PoseCorrectionStats with, without;
  for (const char* name : {"a", "b"}) {
    const bool headroom = std::string(name) == "a";
    Config cm = tiny_config(size_t(0.9 * double(total)));
    cm.residency.pool_headroom = headroom ? 0.25 : 0.0;
    Mapper m(dir / name, cm, true);
    (headroom ? with : without) = m.correct_poses(shifted(m, 0, kDelta), {}, 0);
    EXPECT_EQ(m.total_gaussians(), total);
    EXPECT_EQ(m.budget(), cm.residency.budget_gaussians);  // restored after the batch
    if (headroom) EXPECT_GT(m.peak_resident_gaussians(), cm.residency.budget_gaussians);
    else EXPECT_LE(m.peak_resident_gaussians(), cm.residency.budget_gaussians);
  }
  EXPECT_TRUE(with.batch);
  EXPECT_FALSE(without.batch);
  EXPECT_EQ(with.gaussians_moved, without.gaussians_moved);
  EXPECT_EQ(with.gaussians_moved, total);
}

// A folder saved before the keyframe->chunk index existed: the correction visits every chunk and
// still moves every Gaussian of the corrected keyframes.
TEST(MapperCorrection, MapWithoutSavedIndexVisitsEveryChunk) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const Config c = tiny_config(200'000);
  map_wall(dir / "m", c, 6);
  const auto run_state = dir / "m" / "run_state.json";
  nlohmann::json j = read_json_file(run_state);
  ASSERT_TRUE(j.contains("keyframe_chunks"));
  j.erase("keyframe_chunks");
  write_json_atomically(run_state, j, false);
  const auto before = stored(dir / "m", c.store.chunk_size, UINT32_MAX);
  size_t of_moved = 0;
  for (const auto& [k, v] : before) of_moved += k[0] >= 3;
  size_t chunks = 0;
  {
    Mapper m(dir / "m", c, true);
    chunks = m.chunk_count();
    const PoseCorrectionStats s = m.correct_poses(shifted(m, 3, kDelta), {}, 0);
    EXPECT_EQ(s.gaussians_moved, of_moved);
    EXPECT_GE(s.chunks_touched, chunks);
    m.checkpoint({});
  }
  const auto after = stored(dir / "m", c.store.chunk_size, 0);  // every chunk was visited: all filed
  EXPECT_EQ(after.size(), before.size());
}

TEST(MapperCorrection, JunctionIsResetAndRefined) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const Config c = tiny_config(200'000);
  map_wall(dir / "m", c, 6);
  Mapper m(dir / "m", c, true);
  const uint64_t it0 = m.iterations();
  const PoseCorrectionStats s = m.correct_poses(shifted(m, 3, kDelta), {0, 5}, 7);
  EXPECT_EQ(m.iterations(), it0 + 7);
  EXPECT_GT(s.junction_gaussians, 100u);
  EXPECT_GT(s.refine_ms, 0.0);
  EXPECT_GT(s.chunks_touched, 0u);
  EXPECT_THROW(m.correct_poses({{99u, SE3()}}, {}, 0), Error);
  EXPECT_THROW(m.correct_poses({}, {42u}, 0), Error);
  EXPECT_THROW(m.correct_poses({{1u, SE3()}, {1u, SE3()}}, {}, 0), Error);
}

}  // namespace
}  // namespace chungs
