// The keyframe grid and CaRtGS's usage rule.
#include <gtest/gtest.h>

#include <map>

#include "chungs/common/error.hpp"
#include "chungs/mapping/keyframe_selector.hpp"

namespace chungs {
namespace {

TEST(KeyframeSelector, OnTheGridPicksOnlyInTheLatestKeyframesCell) {
  KeyframeSelectorConfig c;
  c.around_latest = false;
  c.cell_size = 200;
  KeyframeSelector s(c);
  s.add(0, {10, 0, 5});
  s.add(1, {150, 0, 20});
  s.add(2, {250, 0, 30});  // next cell along x
  s.add(3, {260, 5, 40});
  std::mt19937_64 rng(1);
  for (int i = 0; i < 50; ++i) {
    const uint32_t id = s.pick(rng);
    EXPECT_TRUE(id == 2 || id == 3) << id;
  }
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{2, 3}));
}

TEST(KeyframeSelector, AroundTheLatestKeyframeTheCandidatesCrossTheGridBorder) {
  KeyframeSelectorConfig c;
  c.cell_size = 200;  // the paper's
  KeyframeSelector s(c);
  s.add(0, {-5, 0, 0});
  s.add(1, {120, 0, 3});   // 101.0 m from the latest: out
  s.add(2, {150, 0, 20});  // the grid's other cell, 51 m away
  s.add(3, {199, 2, 1});
  s.add(4, {221, 0, 0});  // latest, in the next grid cell
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{2, 3, 4}));
  std::mt19937_64 rng(2);
  std::map<uint32_t, int> seen;
  for (int i = 0; i < 100; ++i) ++seen[s.pick(rng)];
  EXPECT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen.count(1), 0u);
}

TEST(KeyframeSelector, AWindowNarrowsTheCellUntilTheNextKeyframe) {
  KeyframeSelector s;
  for (uint32_t i = 0; i < 6; ++i) s.add(i, {10.0 * i, 0, 0});
  s.restrict_to({4, 3});
  EXPECT_TRUE(s.restricted());
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{3, 4, 5})) << "the latest keyframe is always one";
  std::mt19937_64 rng(3);
  for (int i = 0; i < 60; ++i) {
    const uint32_t id = s.pick(rng);
    EXPECT_TRUE(id >= 3) << id;
  }
  s.add(6, {60, 0, 0});
  EXPECT_FALSE(s.restricted());
  EXPECT_EQ(s.candidates().size(), 7u);
}

TEST(KeyframeSelector, CandidatesAreCappedToTheNearestWithTheLatestAmongThem) {
  KeyframeSelectorConfig c;
  c.max_candidates = 3;
  KeyframeSelector s(c);
  // Along a street a metre apart, then back to x = 2.5: the nearest three are 2, 3 and the latest.
  for (uint32_t i = 0; i < 8; ++i) s.add(i, {double(i), 0, 0});
  s.add(8, {2.5, 0, 0});
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{2, 3, 8}));
  std::mt19937_64 rng(4);
  std::map<uint32_t, int> seen;
  for (int i = 0; i < 100; ++i) ++seen[s.pick(rng)];
  EXPECT_EQ(seen.size(), 3u);
  for (const auto& [id, n] : seen) EXPECT_TRUE(id == 2 || id == 3 || id == 8) << id;
  // A new keyframe moves the cap with it.
  s.add(9, {7.2, 0, 0});
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{6, 7, 9}));
  c.max_candidates = 0;  // no cap
  KeyframeSelector all(c);
  for (uint32_t i = 0; i < 8; ++i) all.add(i, {double(i), 0, 0});
  EXPECT_EQ(all.candidates().size(), 8u);
}

TEST(KeyframeSelector, ACachedCandidateListFollowsEveryAddAndWindow) {
  KeyframeSelector s;
  for (uint32_t i = 0; i < 4; ++i) s.add(i, {10.0 * i, 0, 0});
  EXPECT_EQ(s.candidates().size(), 4u);
  s.restrict_to({2});
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{2, 3}));
  s.add(1, {10000, 0, 0});  // an existing keyframe moved far away (a loop correction) and made latest
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{1}));
}

TEST(KeyframeSelector, ACellPickRangesBeyondTheWindowAndSaysWhichAreInIt) {
  KeyframeSelector s;
  for (uint32_t i = 0; i < 6; ++i) s.add(i, {10.0 * i, 0, 0});
  s.restrict_to({4});
  EXPECT_FALSE(s.in_window(0));
  EXPECT_TRUE(s.in_window(4));
  EXPECT_TRUE(s.in_window(5)) << "the latest keyframe";
  std::mt19937_64 rng(4);
  std::map<uint32_t, int> seen;
  for (int i = 0; i < 200; ++i) ++seen[s.pick(rng, PickScope::cell)];
  EXPECT_EQ(seen.size(), 6u) << "every keyframe of the cell is picked";
  for (int i = 0; i < 50; ++i) EXPECT_GE(s.pick(rng, PickScope::window), 4u);
  s.add(6, {60, 0, 0});
  EXPECT_TRUE(s.in_window(0)) << "no window: every keyframe is in";
}

TEST(KeyframeSelector, UnderAWindowTheCellShrinksToTheBudgetCell) {
  KeyframeSelector s;  // the defaults: a 600 m cell, 200 m under a window
  const double at[] = {0, 150, 250, 290, 300};
  for (uint32_t i = 0; i < 5; ++i) s.add(i, {at[i], 0, 0});
  EXPECT_EQ(s.candidates().size(), 5u) << "300 m from the latest is still in a 600 m cell";
  s.restrict_to({3});
  EXPECT_EQ(s.candidates(), (std::vector<uint32_t>{3, 4}));
  std::mt19937_64 rng(5);
  std::map<uint32_t, int> seen;
  for (int i = 0; i < 200; ++i) ++seen[s.pick(rng, PickScope::cell)];
  // Beyond the window, only what lies within 100 m of the latest keyframe.
  EXPECT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen.count(0) + seen.count(1), 0u);
  EXPECT_GT(seen[2], 0);
  s.add(5, {310, 0, 0});
  EXPECT_EQ(s.candidates().size(), 5u) << "the next keyframe has no window: the 600 m cell again (0 is 310 m away)";
}

TEST(KeyframeSelector, SpendsUsesThenRefillsWithALossBonus) {
  KeyframeSelectorConfig c;
  c.new_uses = 2;
  KeyframeSelector s(c);
  for (uint32_t i = 0; i < 8; ++i) s.add(i, {double(i), 0, 0});
  std::mt19937_64 rng(4);
  std::map<uint32_t, int> count;
  for (int k = 0; k < 16; ++k) ++count[s.pick(rng)];
  for (uint32_t i = 0; i < 8; ++i) EXPECT_EQ(count[i], 2) << "keyframe " << i;  // uses are exact
  for (uint32_t i = 0; i < 8; ++i) s.report_loss(i, double(i == 5 || i == 2 ? 10 + i : i * 0.1));
  // None left: all get +1, the top quarter by loss (2 of 8: keyframes 5 and 2) another +1; the
  // pick then spends one.
  const uint32_t first = s.pick(rng);
  int total = 0;
  for (uint32_t i = 0; i < 8; ++i) {
    const int expect = 1 + (i == 5 || i == 2 ? 1 : 0) - (i == first ? 1 : 0);
    EXPECT_EQ(s.usage(i).uses, expect) << "keyframe " << i;
    total += s.usage(i).uses;
  }
  EXPECT_EQ(total, 9);
}

TEST(KeyframeSelector, PickIsWeightedByRemainingUses) {
  KeyframeSelectorConfig c;
  c.new_uses = 1;
  KeyframeSelector s(c);
  s.add(0, {0, 0, 0}, 3000);
  s.add(1, {1, 0, 0}, 1000);
  std::mt19937_64 rng(2);
  int zero = 0;
  for (int k = 0; k < 2000; ++k) zero += s.pick(rng) == 0;
  // The first 2000 of 4000 uses: expected share 0.75 early, drifting; keyframe 0 dominates.
  EXPECT_GT(zero, 1350);
  EXPECT_LT(zero, 1650);
}

TEST(KeyframeSelector, RefusesAnEmptyPick) {
  KeyframeSelector s;
  std::mt19937_64 rng(1);
  EXPECT_THROW(s.pick(rng), Error);
  EXPECT_THROW(s.report_loss(3, 1.0), Error);
}

}  // namespace
}  // namespace chungs

namespace chungs {
namespace {

TEST(KeyframeSelector, GiveBackReturnsTheUseAPickTook) {
  KeyframeSelector s;
  for (uint32_t i = 0; i < 5; ++i) s.add(i, Eigen::Vector3d(double(i), 0.5 * i, 0));
  std::mt19937_64 rng(3);
  const uint32_t id = s.pick(rng);
  const int after_pick = s.usage(id).uses;
  s.give_back(id);
  EXPECT_EQ(s.usage(id).uses, after_pick + 1);
  EXPECT_THROW(s.give_back(99), Error);
}

}  // namespace
}  // namespace chungs
