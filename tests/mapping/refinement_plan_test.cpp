// The refinement after the last frame (mapper.final_iterations): its steps spread over every keyframe,
// in groups of consecutive keyframes whose views fit the budget, shuffled within a group (issue 19).
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/refinement_plan.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

// A drive past chunks along x: keyframe k sees chunks k .. k + span - 1, each of random size.
std::vector<std::vector<ChunkCount>> drive(size_t keyframes, int span, std::mt19937_64& rng) {
  std::vector<uint64_t> sizes(keyframes + size_t(span));
  for (uint64_t& s : sizes) s = std::uniform_int_distribution<uint64_t>(50, 400)(rng);
  std::vector<std::vector<ChunkCount>> views(keyframes);
  for (size_t k = 0; k < keyframes; ++k)
    for (int j = 0; j < span; ++j) views[k].push_back({ChunkId(k + size_t(j)), sizes[k + size_t(j)]});
  return views;
}

TEST(RefinementPlan, GroupsFitTheBudgetCoverEveryKeyframeAndShareTheStepsByTheirSize) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const size_t keyframes = std::uniform_int_distribution<size_t>(1, 300)(rng);
    const int span = std::uniform_int_distribution<int>(1, 12)(rng);
    const auto views = drive(keyframes, span, rng);
    const uint64_t fit = std::uniform_int_distribution<uint64_t>(100, 20000)(rng);
    const uint64_t steps = std::uniform_int_distribution<uint64_t>(0, 5000)(rng);
    const std::vector<RefinementGroup> groups = plan_refinement(views, fit, steps);
    ASSERT_FALSE(groups.empty());
    size_t next = 0;
    uint64_t total = 0;
    for (size_t g = 0; g < groups.size(); ++g) {
      const RefinementGroup& gr = groups[g];
      ASSERT_EQ(gr.begin, next) << "trial " << trial << ": group " << g << " does not follow the one before";
      ASSERT_GT(gr.end, gr.begin);
      next = gr.end;
      std::map<ChunkId, uint64_t> held;
      for (size_t k = gr.begin; k < gr.end; ++k)
        for (const ChunkCount& c : views[k]) held[c.id] = c.count;
      uint64_t sum = 0;
      for (const auto& [id, n] : held) sum += n;
      if (gr.end - gr.begin > 1) {
        EXPECT_LE(sum, fit) << "trial " << trial << ", group " << g;
      }
      if (g + 1 < groups.size()) {
        // It ended because the next keyframe would not have fitted.
        for (const ChunkCount& c : views[gr.end]) held[c.id] = c.count;
        uint64_t with_next = 0;
        for (const auto& [id, n] : held) with_next += n;
        EXPECT_GT(with_next, fit) << "trial " << trial << ", group " << g << " ended early";
      }
      const double exact = double(steps) * double(gr.end - gr.begin) / double(keyframes);
      EXPECT_LE(std::abs(double(gr.steps) - exact), 1.0) << "trial " << trial << ", group " << g;
      total += gr.steps;
    }
    EXPECT_EQ(next, keyframes);
    EXPECT_EQ(total, steps) << "trial " << trial;
  }
}

TEST(RefinementPlan, AMapThatFitsIsOneGroupAndHugeCountsDoNotOverflow) {
  std::mt19937_64 rng(3);
  const auto views = drive(40, 5, rng);
  const auto one = plan_refinement(views, 1'000'000, 123);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].steps, 123u);
  const uint64_t huge = (uint64_t(1) << 63) + 11;
  uint64_t total = 0;
  for (const RefinementGroup& g : plan_refinement(views, 600, huge)) total += g.steps;
  EXPECT_EQ(total, huge);
  EXPECT_THROW(plan_refinement(views, 0, 10), Error);
  EXPECT_TRUE(plan_refinement({}, 10, 10).empty());
}

TEST(MapperRefine, EveryKeyframeIsTrainedInGroupsUnderTheBudgetInARandomOrder) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.store.chunk_size = 0.25;  // many chunks along the wall, so that the budget cuts the drive into groups
  const test::WallSequence seq(30, 64, 48, 0.3);  // 8.7 m of keyframes, a view 4 m wide
  uint64_t map_size = 0;
  {
    Mapper m(dir / "probe", c, false);
    for (size_t i = 0; i < 30; ++i) {
      const Frame f = seq.frame(i);
      m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    }
    map_size = m.total_gaussians();
  }
  ASSERT_GT(map_size, 2000u);
  c.residency.budget_gaussians = map_size * 3 / 4;  // under the map; groups of several views
  Mapper m(dir / "map", c, false);
  for (size_t i = 0; i < 30; ++i) {
    const Frame f = seq.frame(i);
    m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
  }
  const uint64_t loads_before = m.io_stats().pool_loads;
  std::vector<uint32_t> order;
  const uint64_t steps = 75;  // 2.5 a keyframe
  const Mapper::RefineStats r = m.refine(steps, [&](uint32_t k) {
    order.push_back(k);
    EXPECT_LE(m.resident_gaussians(), m.budget());
  });
  EXPECT_EQ(r.steps, steps);
  ASSERT_EQ(order.size(), steps);
  EXPECT_GE(r.groups, 2u) << "the map is more than the budget: its keyframes cannot be one group";
  EXPECT_LE(r.groups, 6u) << "groups of several keyframes";
  std::map<uint32_t, int> count;
  for (uint32_t k : order) ++count[k];
  EXPECT_EQ(count.size(), m.keyframes().size()) << "every keyframe is trained";
  for (const auto& [k, n] : count) {
    EXPECT_GE(n, 1) << "keyframe " << k;
    EXPECT_LE(n, 4) << "keyframe " << k;
  }
  // Groups in the order of the drive: a step never goes back further than a group is wide.
  const uint32_t width = 20;
  uint32_t highest = 0;
  for (size_t i = 0; i < order.size(); ++i) {
    EXPECT_LT(highest, order[i] + width) << "step " << i << " went back to keyframe " << order[i] << " after "
                                         << highest;
    highest = std::max(highest, order[i]);
  }
  // Not the order of the drive: a shuffled group's steps go back and forth.
  size_t backwards = 0;
  for (size_t i = 1; i < order.size(); ++i) backwards += order[i] < order[i - 1];
  EXPECT_GT(backwards, steps / 5) << ::testing::PrintToString(order) << " groups " << r.groups;
  EXPECT_GT(m.io_stats().pool_loads, loads_before) << "the early groups' chunks were evicted and came back";
  EXPECT_EQ(m.refine(0).steps, 0u);
}

TEST(MapperRefine, NeedsAKeyframe) {
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  Mapper m(dir / "map", c, false);
  EXPECT_EQ(m.refine(0).steps, 0u);
  EXPECT_THROW(m.refine(5), Error);
}

}  // namespace
}  // namespace chungs
