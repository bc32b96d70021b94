// The refinement after the last frame (mapper.final_iterations): its steps spread over every keyframe,
// in groups of places whose views fit the budget, shuffled within a group (issue 19).
#include "chungs/mapping/refinement_plan.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
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

PackedViews pack(const std::vector<std::vector<ChunkCount>>& views) {
  PackedViews packed;
  for (const auto& v : views) packed.add(v);
  return packed;
}

// Distinct chunks' Gaussians of a set of keyframes.
uint64_t held_by(const std::vector<std::vector<ChunkCount>>& views, const std::vector<size_t>& keyframes) {
  std::map<ChunkId, uint64_t> held;
  for (size_t k : keyframes)
    for (const ChunkCount& c : views[k]) held[c.id] = c.count;
  uint64_t sum = 0;
  for (const auto& [id, n] : held) sum += n;
  return sum;
}

// Every keyframe in exactly one group; groups fit; each group ended because no keyframe it could
// take (sharing a chunk with it, or the earliest left) fitted; shares within one step of exact.
void expect_valid_plan(const std::vector<std::vector<ChunkCount>>& views, uint64_t fit, uint64_t steps,
                       const std::vector<RefinementGroup>& groups, const std::string& what) {
  const size_t keyframes = views.size();
  std::vector<int> group_of(keyframes, -1);
  size_t before = 0;
  uint64_t total = 0;
  for (size_t g = 0; g < groups.size(); ++g) {
    const RefinementGroup& gr = groups[g];
    ASSERT_FALSE(gr.keyframes.empty()) << what << ", group " << g;
    for (size_t k : gr.keyframes) {
      ASSERT_LT(k, keyframes) << what;
      ASSERT_EQ(group_of[k], -1) << what << ": keyframe " << k << " in two groups";
      group_of[k] = int(g);
    }
    const uint64_t sum = held_by(views, gr.keyframes);
    if (gr.keyframes.size() > 1) {
      EXPECT_LE(sum, fit) << what << ", group " << g;
    }
    std::set<ChunkId> chunks;
    for (size_t k : gr.keyframes)
      for (const ChunkCount& c : views[k]) chunks.insert(c.id);
    size_t earliest_left = keyframes;
    for (size_t k = 0; k < keyframes; ++k)
      if (group_of[k] == -1) {
        earliest_left = k;
        break;
      }
    for (size_t k = 0; k < keyframes; ++k) {
      if (group_of[k] != -1) continue;
      bool shares = k == earliest_left;
      for (const ChunkCount& c : views[k]) shares = shares || chunks.count(c.id);
      if (!shares) continue;
      std::vector<size_t> with = gr.keyframes;
      with.push_back(k);
      EXPECT_GT(held_by(views, with), fit)
          << what << ", group " << g << " ended although keyframe " << k << " fits";
    }
    const double exact = double(steps) * double(gr.keyframes.size()) / double(keyframes);
    EXPECT_LE(std::abs(double(gr.steps) - exact), 1.0) << what << ", group " << g;
    total += gr.steps;
    before += gr.keyframes.size();
  }
  EXPECT_EQ(before, keyframes) << what;
  EXPECT_EQ(total, steps) << what;
}

TEST(RefinementPlan, GroupsFitTheBudgetCoverEveryKeyframeAndShareTheStepsByTheirSize) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const size_t keyframes = std::uniform_int_distribution<size_t>(1, 300)(rng);
    const int span = std::uniform_int_distribution<int>(1, 12)(rng);
    auto views = drive(keyframes, span, rng);
    // Some keyframes look elsewhere: chunks no other keyframe sees.
    for (size_t k = 0; k < keyframes; ++k)
      if (rng() % 7 == 0)
        views[k] = {{ChunkId(1'000'000 + k), std::uniform_int_distribution<uint64_t>(50, 900)(rng)}};
    const uint64_t fit = std::uniform_int_distribution<uint64_t>(100, 20000)(rng);
    const uint64_t steps = std::uniform_int_distribution<uint64_t>(0, 5000)(rng);
    const std::vector<RefinementGroup> groups = plan_refinement(pack(views), fit, steps);
    ASSERT_FALSE(groups.empty());
    expect_valid_plan(views, fit, steps, groups, "trial " + std::to_string(trial));
  }
}

TEST(RefinementPlan, AStreetDrivenTwiceIsTrainedByBothPassesTogether) {
  // Out along chunks 0..n+span-1 and back: keyframe n + k sees what keyframe n - 1 - k saw. Cut in the
  // order of the drive, a group of the way out would hold none of the way back.
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 10; ++trial) {
    const size_t n = std::uniform_int_distribution<size_t>(40, 200)(rng);
    const int span = std::uniform_int_distribution<int>(3, 10)(rng);
    auto views = drive(n, span, rng);
    for (size_t k = 0; k < n; ++k) views.push_back(views[n - 1 - k]);
    std::vector<size_t> all(2 * n);
    for (size_t k = 0; k < all.size(); ++k) all[k] = k;
    // A fifth to a tenth of the map, or the largest view.
    uint64_t fit = held_by(views, all) / std::uniform_int_distribution<uint64_t>(5, 10)(rng);
    for (size_t k = 0; k < n; ++k) fit = std::max(fit, held_by(views, {k}));
    const auto groups = plan_refinement(pack(views), fit, 1000);
    ASSERT_GE(groups.size(), 2u) << "trial " << trial;
    expect_valid_plan(views, fit, 1000, groups, "trial " + std::to_string(trial));
    std::vector<size_t> group_of(2 * n);
    for (size_t g = 0; g < groups.size(); ++g)
      for (size_t k : groups[g].keyframes) group_of[k] = g;
    size_t together = 0;
    for (size_t k = 0; k < n; ++k) together += group_of[k] == group_of[2 * n - 1 - k];
    EXPECT_GE(together, n * 9 / 10) << "trial " << trial << ": a place's two views in different groups";
  }
}

TEST(RefinementPlan, AMapThatFitsIsOneGroupAndHugeCountsDoNotOverflow) {
  std::mt19937_64 rng(3);
  const auto views = drive(40, 5, rng);
  const auto one = plan_refinement(pack(views), 1'000'000, 123);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].steps, 123u);
  const uint64_t huge = (uint64_t(1) << 63) + 11;
  uint64_t total = 0;
  for (const RefinementGroup& g : plan_refinement(pack(views), 600, huge)) total += g.steps;
  EXPECT_EQ(total, huge);
  EXPECT_THROW(plan_refinement(pack(views), 0, 10), Error);
  EXPECT_TRUE(plan_refinement(PackedViews{}, 10, 10).empty());
}

TEST(RefinementPlan, PackedViewsNumberEachChunkOnceAndKeepEveryViewsEntries) {
  std::mt19937_64 rng(5);
  auto views = drive(60, 7, rng);
  views[20].clear();  // a keyframe that sees nothing
  const PackedViews packed = pack(views);
  ASSERT_EQ(packed.size(), views.size());
  std::map<uint32_t, ChunkId> chunk_of;
  std::set<ChunkId> distinct;
  for (size_t k = 0; k < views.size(); ++k) {
    ASSERT_EQ(packed.end(k) - packed.begin(k), views[k].size()) << "view " << k;
    for (uint32_t e = packed.begin(k); e < packed.end(k); ++e) {
      const ChunkCount& c = views[k][e - packed.begin(k)];
      distinct.insert(c.id);
      EXPECT_EQ(packed.count(e), c.count) << "view " << k;
      const auto [it, fresh] = chunk_of.try_emplace(packed.number(e), c.id);
      EXPECT_EQ(it->second, c.id) << "number " << packed.number(e) << " names two chunks";
    }
  }
  EXPECT_EQ(packed.chunks(), distinct.size());
  EXPECT_EQ(chunk_of.size(), distinct.size());
  PackedViews big;
  EXPECT_THROW(big.add({{ChunkId(1), uint64_t(1) << 32}}), Error);
  EXPECT_EQ(big.size(), 0u) << "a refused view is not half added";
}

TEST(RefinementPlan, RoundsVisitTheGroupsInTurnEachWithItsShareOfItsSteps) {
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<RefinementGroup> groups(std::uniform_int_distribution<size_t>(1, 30)(rng));
    for (RefinementGroup& g : groups) {
      g.steps = std::uniform_int_distribution<uint64_t>(0, 200)(rng);
      g.keyframes.resize(std::uniform_int_distribution<size_t>(1, 60)(rng));
    }
    const size_t rounds = std::uniform_int_distribution<size_t>(1, 12)(rng);
    const uint64_t min_visit = trial % 2 ? 1 : std::uniform_int_distribution<uint64_t>(1, 40)(rng);
    const std::vector<RefinementVisit> visits = refinement_visits(groups, rounds, min_visit);
    // A group's visits: as many as its steps allow at min_visit each (one at least, at most rounds),
    // but enough that none trains its keyframes more than once each (ceil(steps / keyframes)).
    const auto visits_of = [&](const RefinementGroup& g) {
      const uint64_t s = g.steps, n = g.keyframes.size();
      return std::max(std::clamp<uint64_t>(s / min_visit, 1, rounds), (s + n - 1) / n);
    };
    uint64_t all_rounds = rounds;
    for (const RefinementGroup& g : groups) all_rounds = std::max(all_rounds, visits_of(g));
    std::vector<uint64_t> got(groups.size(), 0);
    std::vector<size_t> seen(groups.size(), 0);
    size_t round = 0, last = 0;
    for (size_t i = 0; i < visits.size(); ++i) {
      const RefinementVisit& v = visits[i];
      ASSERT_LT(v.group, groups.size());
      EXPECT_GT(v.steps, 0u) << "trial " << trial << ", visit " << i;
      if (i > 0 && v.group <= last) ++round;  // the groups in turn: a new round starts at a lower group
      last = v.group;
      const uint64_t s = groups[v.group].steps, n = groups[v.group].keyframes.size();
      const double want = double(visits_of(groups[v.group]));
      EXPECT_LE(std::abs(double(v.steps) - double(s) / want), 1.0) << "trial " << trial << ", visit " << i;
      EXPECT_LE(v.steps, std::max<uint64_t>(n, 1) + 1) << "trial " << trial << ", visit " << i;
      // Visits no shorter than min_visit, unless that would train the group's keyframes more than once.
      if (s >= min_visit && visits_of(groups[v.group]) == std::clamp<uint64_t>(s / min_visit, 1, rounds)) {
        EXPECT_GE(v.steps + 1, min_visit) << "trial " << trial << ", visit " << i;
      }
      got[v.group] += v.steps;
      ++seen[v.group];
    }
    EXPECT_LE(round + 1, all_rounds) << "trial " << trial;
    for (size_t g = 0; g < groups.size(); ++g) {
      const uint64_t s = groups[g].steps;
      EXPECT_EQ(got[g], s) << "trial " << trial << ", group " << g;
      EXPECT_EQ(seen[g], std::min<uint64_t>(visits_of(groups[g]), s)) << "trial " << trial << ", group " << g;
    }
    // Spread over the rounds, not bunched in the first ones: before group a's j-th visit (from 0) come
    // about (j + 1) v_b / v_a of group b's, whatever their counts of visits v.
    std::vector<size_t> done(groups.size(), 0);
    for (const RefinementVisit& v : visits) {
      const size_t a = v.group, j = done[a]++;
      for (size_t b = 0; b < groups.size(); ++b) {
        if (b == a || seen[b] == 0) continue;
        const double expect = double(j + 1) * double(seen[b]) / double(seen[a]);
        EXPECT_LE(std::abs(double(done[b]) - expect), 2.0) << "trial " << trial << ", groups " << a << ", " << b;
      }
    }
  }
  // Steps beyond what passes of one step a keyframe can list: the visits are held to 2^20, and longer.
  const std::vector<RefinementGroup> huge{{{0}, (uint64_t(1) << 63) + 7}, {{1}, 3}};
  uint64_t total = 0;
  const std::vector<RefinementVisit> few = refinement_visits(huge, 5, 1);
  for (const RefinementVisit& v : few) total += v.steps;
  EXPECT_EQ(total, (uint64_t(1) << 63) + 10);
  EXPECT_LE(few.size(), (size_t(1) << 20) + 3);
  EXPECT_THROW(refinement_visits(huge, 0, 1), Error);
  EXPECT_THROW(refinement_visits(huge, 3, 0), Error);
  EXPECT_TRUE(refinement_visits({}, 3, 1).empty());
}

// Under a budget of about one view the groups hold two views and get two steps each: sixteen rounds
// would load a whole group for each step; a visit of at least four steps keeps each group to one.
TEST(RefinementPlan, GroupsWithFewStepsAreVisitedOnceNotOnceARound) {
  std::vector<RefinementGroup> groups(500);
  for (RefinementGroup& g : groups) {
    g.steps = 2;
    g.keyframes = {0, 1};
  }
  groups[7].steps = 64;  // a place with many views: 16 visits of 4
  groups[7].keyframes.resize(16);
  const std::vector<RefinementVisit> visits = refinement_visits(groups, 16, 4);
  EXPECT_EQ(visits.size(), 499u + 16u);
  size_t of7 = 0;
  for (const RefinementVisit& v : visits) {
    if (v.group == 7) {
      ++of7;
      EXPECT_EQ(v.steps, 4u);
    } else {
      EXPECT_EQ(v.steps, 2u);
    }
  }
  EXPECT_EQ(of7, 16u);
}

// More refinement steps under a budget of less than a view (groups of one to three views): visits of a
// few steps each trained one view several times in a row and lowered the map (bench/README.md, issue
// 19). However many the steps, a visit is at most one pass over its group.
TEST(RefinementPlan, MoreStepsMakeMoreVisitsNotVisitsThatTrainAViewTwice) {
  std::mt19937_64 rng(11);
  for (uint64_t per_keyframe : {1, 2, 7, 30}) {
    std::vector<RefinementGroup> groups(std::uniform_int_distribution<size_t>(50, 120)(rng));
    for (RefinementGroup& g : groups) {
      g.keyframes.resize(std::uniform_int_distribution<size_t>(1, 3)(rng));
      g.steps = per_keyframe * g.keyframes.size();
    }
    groups[3].keyframes.resize(40);  // a place seen by many views
    groups[3].steps = per_keyframe * 40;
    std::vector<uint64_t> visits(groups.size(), 0);
    for (const RefinementVisit& v : refinement_visits(groups, 16, 4)) {
      EXPECT_LE(v.steps, std::max<uint64_t>(groups[v.group].keyframes.size(), 4))
          << per_keyframe << " steps a keyframe, group " << v.group;
      ++visits[v.group];
    }
    for (size_t g = 0; g < groups.size(); ++g)
      EXPECT_GE(visits[g], std::min<uint64_t>(per_keyframe, groups[g].steps)) << per_keyframe << " a keyframe, group " << g;
  }
}

TEST(MapperRefine, EveryKeyframeIsTrainedInGroupsUnderTheBudgetInRoundsInARandomOrder) {
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
  c.mapper.refinement_rounds = 3;
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
  // Groups are places along the wall, visited in rounds: a step goes back further than a group is wide
  // only where a round starts again at the first group.
  const uint32_t width = 20;
  uint32_t highest = 0;
  size_t restarts = 0;
  for (size_t i = 0; i < order.size(); ++i) {
    if (order[i] + width <= highest) {
      ++restarts;
      highest = order[i];
    }
    highest = std::max(highest, order[i]);
  }
  EXPECT_GE(restarts, 1u) << "a later round trains the first group again: " << ::testing::PrintToString(order);
  EXPECT_LE(restarts + 1, size_t(c.mapper.refinement_rounds)) << ::testing::PrintToString(order);
  // Not the order of the drive: a shuffled group's steps go back and forth.
  size_t backwards = 0;
  for (size_t i = 1; i < order.size(); ++i) backwards += order[i] < order[i - 1];
  EXPECT_GT(backwards, steps / 5) << ::testing::PrintToString(order) << " groups " << r.groups;
  EXPECT_GT(m.io_stats().pool_loads, loads_before) << "the early groups' chunks were evicted and came back";
  EXPECT_EQ(m.refine(0).steps, 0u);
}

TEST(MapperRefine, StepsScoreEveryPixelWithoutTheWindowsBestViewMasks) {
  // Along a wall under a budget, the window's steps leave out chunks that views gone from it showed on
  // more blocks; the refinement trains every view of a place, so none of its steps does.
  log::set_level(log::Level::Error);
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.store.chunk_size = 0.25;
  c.residency.budget_gaussians = 4000;
  const test::WallSequence seq(40, 64, 48, 0.3);
  Mapper m(dir / "map", c, false);
  for (size_t i = 0; i < 40; ++i) {
    const Frame f = seq.frame(i);
    m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    for (int s = 0; s < 5; ++s) m.step();
  }
  const uint64_t masked = m.window_stats().best_view_steps;
  ASSERT_GT(m.window_stats().narrowed, 0u) << "the budget narrows training to a window";
  ASSERT_GT(masked, 0u) << "the window's steps left out chunks shown better by views gone from it";
  EXPECT_EQ(m.refine(60).steps, 60u);
  EXPECT_EQ(m.window_stats().best_view_steps, masked);
  for (int s = 0; s < 20; ++s) m.step();  // the window's steps mask again afterwards
  EXPECT_GT(m.window_stats().best_view_steps, masked);
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
