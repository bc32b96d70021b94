#include "chungs/pipeline/checkpoint_cadence.hpp"

#include <gtest/gtest.h>

#include <random>

namespace chungs {

TEST(CheckpointCadence, DueByTimeOrKeyframesWhenCheap) {
  const CheckpointCadence c{30, 0, 0.01};
  EXPECT_FALSE(checkpoint_due(c, {29.9, 100, 29.9, 0, 0}));
  EXPECT_TRUE(checkpoint_due(c, {30.0, 0, 30.0, 0, 0}));
  const CheckpointCadence k{0, 5, 0.01};
  EXPECT_FALSE(checkpoint_due(k, {1000, 4, 1000, 0, 0}));
  EXPECT_TRUE(checkpoint_due(k, {1000, 5, 1000, 0, 0}));
  EXPECT_FALSE(checkpoint_due({0, 0, 0.01}, {1e6, 1000000, 1e6, 0, 0}));  // both off
}

// The H100 run that prompted the rule: behind checkpoints cost the optimiser ~290 ms each and wrote
// for ~860 ms; the final one took 1.0-1.4 s of a 103 s run. Bounded one at a time, checkpoints came
// at 30, 60 and 95 s and the run spent 2.17 % of its time on them.
TEST(CheckpointCadence, TheFinalCheckpointIsKeptWithinTheShare) {
  const CheckpointCadence c{30, 0, 0.01};
  EXPECT_TRUE(checkpoint_due(c, {30, 300, 30, 0, 0}));  // the first: nothing spent, nothing known
  const double estimate = final_checkpoint_estimate_ms(860, 1);
  EXPECT_DOUBLE_EQ(estimate, 860);
  EXPECT_FALSE(checkpoint_due(c, {30, 300, 60, 290, estimate}));    // 1,150 ms against 600
  EXPECT_FALSE(checkpoint_due(c, {84, 800, 114, 290, estimate}));   // against 1,140
  EXPECT_TRUE(checkpoint_due(c, {86, 800, 116, 290, estimate}));    // against 1,160
  EXPECT_TRUE(checkpoint_due({30, 0, 0}, {30, 300, 60, 290, estimate}));  // no bound asked
}

TEST(CheckpointCadence, EstimateOfTheFinalCheckpointIsTheMeanWriteOfTheOnesBehind) {
  EXPECT_EQ(final_checkpoint_estimate_ms(0, 0), 0);
  EXPECT_EQ(final_checkpoint_estimate_ms(500, 0), 0);
  EXPECT_DOUBLE_EQ(final_checkpoint_estimate_ms(2592, 3), 864);
}

// A simulated run of random length, checkpoint costs and write times: whenever the rule lets a
// checkpoint begin, the checkpoints so far plus the estimate of the final one fit the share; and over
// a long run with cheap checkpoints the cadence stays that of the clock.
TEST(CheckpointCadence, RandomRunsStayWithinTheShareAndKeepTheClockWhenCheap) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> cost(50, 600), write(200, 2000), length(60, 3000);
  for (int run = 0; run < 200; ++run) {
    const CheckpointCadence c{30, 0, 0.01};
    const double end = length(rng);
    double spent = 0, behind = 0, last = 0;
    size_t count = 0, started = 0;
    for (double t = 0.5; t < end; t += 0.5) {
      const double estimate = final_checkpoint_estimate_ms(behind, count);
      if (!checkpoint_due(c, {t - last, 0, t, spent, estimate})) continue;
      EXPECT_LE(spent + estimate, c.max_share * t * 1000.0 + 1e-9);
      spent += cost(rng);
      behind += write(rng), ++count, ++started;
      last = t;
    }
    EXPECT_GE(started, end >= 30 ? 1u : 0u) << "a run of " << end << " s";
  }
  // Cheap checkpoints (5 ms, written in 20 ms) keep the 30 s cadence: 99 of them in 3,000 s.
  double spent = 0, last = 0;
  size_t n = 0;
  for (double t = 0.5; t < 3000; t += 0.5)
    if (checkpoint_due({30, 0, 0.01}, {t - last, 0, t, spent, n ? 20.0 : 0.0})) spent += 5, last = t, ++n;
  EXPECT_EQ(n, 99u);
}

}  // namespace chungs
