// The real-time matrix of bench/realtime_matrix.sh in test size, on the CPU: a short synthetic street
// at 310x94 with the default mapping settings (the outdoor preset, as `run` applies it), fixed and
// real-time pacing, with the default budget, a third of the map and less than one view needs.
// Asserts the properties the benchmark checks, not timings: a budget does not make the map grow
// (what lies on disk is not sampled again) nor make steps load chunks, every keyframe gets its floor
// of steps, and a real-time intake does not flood the map with Gaussians it never trains.
#include <gtest/gtest.h>

#include "chungs/common/log.hpp"
#include "chungs/config/presets.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/synth/street_dataset.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

struct Cell {
  nlohmann::json report;
  uint64_t total() const { return report["gaussians"]["total"].get<uint64_t>(); }
  const nlohmann::json& pacing() const { return report["pacing"]; }
};

Cell map_street(const std::string& pacing, double speed, size_t budget) {
  log::set_level(log::Level::Warn);
  synth::StreetDatasetOptions so;
  so.street.length_m = 200;
  so.street.seed = 7;
  so.width = 310;
  so.height = 94;
  const synth::StreetDataset street(so);
  test::TempDir dir;
  RunOptions o;
  o.dataset = "synth-street:length=200,width=310,height=94,seed=7";
  o.out = dir / "map";
  Config& c = o.config;  // the defaults, with the outdoor preset `run` picks for a street
  apply_preset(c, "auto", o.dataset);
  c.mapper.device = "cpu";
  c.mapper.pacing = pacing;
  c.mapper.speed = speed;
  c.mapper.iterations_per_keyframe = 10;  // test size (default 30)
  c.mapper.final_iterations = 0;
  c.mapper.eval_keyframe_stride = 0;
  c.mapper.max_saved_renders = 0;
  c.store.durable = false;
  c.keyframes.durable = false;
  if (budget) c.residency.budget_gaussians = budget;
  c.validate();
  Cell cell{run_mapping(o, street)};
  return cell;
}

TEST(RealtimeStreet, BudgetsDoNotGrowTheMapNorMakeStepsLoadAndAnytimeKeepsItsFloor) {
  const Cell fixed = map_street("fixed", 1, 0), fixed_small = map_street("fixed", 1, 8000);
  const Cell fast = map_street("anytime", 2, 0), fast_small = map_street("anytime", 2, 8000);
  const Cell fixed_tiny = map_street("fixed", 1, 3000);
  for (const Cell* c : {&fixed, &fixed_small, &fast, &fast_small, &fixed_tiny})
    std::printf("total %llu, steps/kf %.1f (min after 1st minute %lld), dropped %llu, views over budget %llu, "
                "held-out %.2f dB, chunk loads %llu (waited %llu) in %llu steps, saves %llu\n",
                (unsigned long long)c->total(), c->pacing()["steps_per_keyframe_mean"].get<double>(),
                (long long)c->pacing()["steps_per_keyframe_min_after_first_minute"].get<int64_t>(),
                (unsigned long long)c->pacing()["dropped_keyframes"].get<uint64_t>(),
                (unsigned long long)c->pacing()["views_over_budget"].get<uint64_t>(),
                c->report["held_out"]["mean_psnr"].get<double>(),
                (unsigned long long)c->report["chunk_io"]["loads"].get<uint64_t>(),
                (unsigned long long)c->report["chunk_io"]["waited_loads"].get<uint64_t>(),
                (unsigned long long)c->report["iterations"].get<uint64_t>(),
                (unsigned long long)c->report["chunk_io"]["saves"].get<uint64_t>());
  for (const Cell* c : {&fixed_small, &fast_small, &fixed_tiny})
    std::printf("  %s\n", c->report["chunk_io"]["summary"].get<std::string>().c_str());
  // A third of the map: the steps train on the keyframes whose chunks fit together, so they do not
  // load chunks at every step (the whole 200 m cell, as before the training window: ~2 loads per
  // step, most of them waited for). The far field's chunks, made from picks gathered over several
  // keyframes, are small and many (0.46 loads per step, 0.40 waited, in the real-time cell: 0.1 ms each).
  for (const Cell* c : {&fixed_small, &fast_small}) {
    EXPECT_LE(c->report["gaussians"]["peak_resident"].get<uint64_t>(), 8000u);
    const double steps = double(c->report["iterations"].get<uint64_t>());
    EXPECT_LT(double(c->report["chunk_io"]["loads"].get<uint64_t>()), 0.75 * steps);
    EXPECT_LT(double(c->report["chunk_io"]["waited_loads"].get<uint64_t>()), 0.6 * steps);
    // Keyframes outside the window keep being trained, on the resident part of their views.
    EXPECT_GT(c->pacing()["training_window"]["partial_step_share"].get<double>(), 0.0);
  }
  // Below what one view needs: the farthest chunks stay out of each render, and their screen area
  // is not sampled again.
  EXPECT_GT(fixed_tiny.pacing()["views_over_budget"].get<uint64_t>(), 10u);
  // ... and the pixels those chunks would draw are not scored on window keyframes either.
  EXPECT_GT(fixed_tiny.pacing()["training_window"]["trimmed_step_share"].get<double>(), 0.0);
  EXPECT_LE(fixed_tiny.report["gaussians"]["peak_resident"].get<uint64_t>(), 3000u);
  for (const Cell* c : {&fixed_small, &fixed_tiny}) EXPECT_LT(double(c->total()), 1.25 * double(fixed.total()));
  EXPECT_LT(double(fast_small.total()), 1.25 * double(fast.total()));
  // Fixed pacing: exactly its steps per keyframe.
  EXPECT_DOUBLE_EQ(fixed.pacing()["steps_per_keyframe_mean"].get<double>(), 10.0);
  // Real time at 72 km/h: every keyframe got at least the floor, none only start-up time.
  for (const Cell* c : {&fast, &fast_small}) {
    const int floor = c->pacing()["min_steps_per_keyframe"].get<int>();
    EXPECT_EQ(floor, 10);
    EXPECT_GE(c->pacing()["steps_per_keyframe_lowest_minute"].get<double>(), floor);
    const int64_t least = c->pacing()["steps_per_keyframe_min_after_first_minute"].get<int64_t>();
    if (least >= 0) {
      EXPECT_GE(least, floor);
    }
    // Untrained Gaussians do not pile up: no larger than the fixed run's map by much.
    EXPECT_LT(double(c->total()), 1.5 * double(fixed.total()));
  }
}

}  // namespace
}  // namespace chungs
