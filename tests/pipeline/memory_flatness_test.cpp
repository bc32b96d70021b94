// memory_flatness: the plateau and the deviations are measured only over the samples after the
// resident count reached the budget, against a brute-force computation on random series.
#include "chungs/pipeline/memory_flatness.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace chungs {
namespace {

std::vector<TimelineSample> ramp_then_level(std::mt19937& rng, size_t before, size_t after, uint64_t budget,
                                            double level, double noise, bool vram) {
  std::uniform_real_distribution<double> u(-noise, noise);
  std::vector<TimelineSample> s;
  for (size_t i = 0; i < before + after; ++i) {
    TimelineSample t;
    t.seconds = double(i) * 0.7;
    t.total = 1000 * (i + 1);
    // Before: well below the budget and memory climbing; after: at the budget, memory level.
    t.resident = i < before ? budget * i / (2 * before) : budget - (i % 3);
    t.rss_mb = i < before ? level * double(i + 1) / double(before) * 0.5 : level * (1 + u(rng));
    t.vram_mb = vram ? 2000 + 10 * u(rng) : 0;
    s.push_back(t);
  }
  return s;
}

TEST(MemoryFlatness, MeasuresOnlyAfterTheBudgetIsReached) {
  std::mt19937 rng(11);
  const uint64_t budget = 50000;
  const auto s = ramp_then_level(rng, 40, 101, budget, 800.0, 0.08, true);
  const auto f = memory_flatness(s, budget);
  ASSERT_TRUE(f);
  EXPECT_DOUBLE_EQ(f->reached_seconds, s[40].seconds);
  EXPECT_EQ(f->total_at_reached, s[40].total);
  EXPECT_EQ(f->total_at_end, s.back().total);
  // Brute force over the same samples.
  std::vector<double> after;
  for (size_t i = 40; i < s.size(); ++i) after.push_back(s[i].rss_mb);
  std::vector<double> sorted = after;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];  // 101 samples: odd
  EXPECT_DOUBLE_EQ(f->rss.plateau_mb, median);
  EXPECT_EQ(f->rss.samples, after.size());
  EXPECT_NEAR(f->rss.max_above, (sorted.back() - median) / median, 1e-12);
  EXPECT_NEAR(f->rss.max_below, (median - sorted.front()) / median, 1e-12);
  const double within =
      double(std::count_if(after.begin(), after.end(),
                           [&](double x) { return std::abs(x - median) <= 0.05 * median; })) /
      double(after.size());
  EXPECT_NEAR(f->rss.within_share, within, 1e-12);
  EXPECT_GT(f->rss.within_share, 0.3);
  EXPECT_LT(f->rss.within_share, 0.9);  // noise of +-8 % puts some samples outside 5 %
  size_t last_out = 0;                  // settled at the sample after the last one outside 5 %
  for (size_t i = 0; i < after.size(); ++i)
    if (std::abs(after[i] - median) > 0.05 * median) last_out = i + 1;
  ASSERT_LT(last_out, after.size());
  EXPECT_DOUBLE_EQ(f->rss.settled_after_s, s[40 + last_out].seconds - s[40].seconds);
  ASSERT_TRUE(f->vram);
  EXPECT_DOUBLE_EQ(f->vram->settled_after_s, 0.0);
  EXPECT_DOUBLE_EQ(f->vram->within_share, 1.0);
  EXPECT_LT(f->vram->max_above, 0.01);
}

// Host memory keeps the images of the latest keyframes (keyframes.max_in_memory): RSS climbs until the map
// has that many, after the budget was reached on a short drive. The measure starts at the later of the two,
// and at the budget where the keyframes came first or never came.
TEST(MemoryFlatness, StartsOnceTheKeyframeImagesAreHeldWhenThatComesLater) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-0.01, 0.01);
  const uint64_t budget = 20000;
  std::vector<TimelineSample> s;
  for (size_t i = 0; i < 120; ++i) {
    TimelineSample t;
    t.seconds = 0.5 + double(i);
    t.keyframes = 3 * i;
    t.total = 500 * (i + 1);
    t.resident = i < 10 ? budget * i / 20 : budget;              // the budget from sample 10
    t.rss_mb = (i < 50 ? 100.0 + 3.0 * double(i) : 250.0) * (1 + u(rng));  // the images until 150 keyframes
    s.push_back(t);
  }
  const auto held = memory_flatness(s, budget, 150);
  ASSERT_TRUE(held);
  EXPECT_DOUBLE_EQ(held->reached_seconds, s[10].seconds);
  ASSERT_TRUE(held->keyframes_held_seconds);
  EXPECT_DOUBLE_EQ(*held->keyframes_held_seconds, s[50].seconds);
  EXPECT_DOUBLE_EQ(held->from_seconds, s[50].seconds);
  EXPECT_EQ(held->rss.samples, 70u);
  EXPECT_DOUBLE_EQ(held->rss.within_share, 1.0);
  EXPECT_DOUBLE_EQ(held->to_json()["from_seconds"].get<double>(), s[50].seconds);
  // Measured from the budget, the climb shows: the same series is not level.
  const auto budget_only = memory_flatness(s, budget);
  ASSERT_TRUE(budget_only);
  EXPECT_DOUBLE_EQ(budget_only->from_seconds, s[10].seconds);
  EXPECT_FALSE(budget_only->keyframes_held_seconds);
  EXPECT_TRUE(budget_only->to_json()["keyframes_held_seconds"].is_null());
  EXPECT_LT(budget_only->rss.within_share, 0.9);
  // Held before the budget (a small cache): from the budget.
  const auto early = memory_flatness(s, budget, 9);
  ASSERT_TRUE(early && early->keyframes_held_seconds);
  EXPECT_DOUBLE_EQ(*early->keyframes_held_seconds, s[3].seconds);
  EXPECT_DOUBLE_EQ(early->from_seconds, s[10].seconds);
  // Never held (a cache larger than the drive), or held at the last sample only: from the budget.
  EXPECT_DOUBLE_EQ(memory_flatness(s, budget, 400)->from_seconds, s[10].seconds);
  EXPECT_FALSE(memory_flatness(s, budget, 400)->keyframes_held_seconds);
  EXPECT_DOUBLE_EQ(memory_flatness(s, budget, 3 * 119)->from_seconds, s[10].seconds);
}

TEST(MemoryFlatness, NoneBeforeTheBudgetAndNoVramOnTheCpu) {
  std::mt19937 rng(5);
  auto s = ramp_then_level(rng, 30, 20, 10000, 100.0, 0.01, false);
  const auto f = memory_flatness(s, 10000);
  ASSERT_TRUE(f);
  EXPECT_FALSE(f->vram);
  EXPECT_FALSE(f->to_json().contains("vram"));
  EXPECT_DOUBLE_EQ(f->rss.within_share, 1.0);
  s.back().rss_mb *= 1.2;  // a last step up: memory never settled
  EXPECT_DOUBLE_EQ(memory_flatness(s, 10000)->rss.settled_after_s, -1.0);
  s.resize(30);  // cut before the budget was reached
  EXPECT_FALSE(memory_flatness(s, 10000));
  EXPECT_FALSE(memory_flatness(s, 0));
}

}  // namespace
}  // namespace chungs
