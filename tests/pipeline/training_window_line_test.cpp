// The run summary's lines on pacing and on the training window: the report's figures, what bounds the
// steps, and nothing on the window without narrowing.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "chungs/pipeline/run_report.hpp"

namespace chungs {
namespace {

TEST(TrainingWindowLine, StatesTheReportsFiguresWhenTheBudgetNarrowedTraining) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.05, 0.95);
  for (int i = 0; i < 20; ++i) {
    const double narrowed = u(rng), kf = 10 + 300 * u(rng), cell = kf + 100 * u(rng), reach = 200 * u(rng),
                 partial = u(rng) / 2;
    nlohmann::json p;
    p["training_window"] = {{"narrowed_share", narrowed}, {"mean_keyframes", kf}, {"mean_cell_keyframes", cell},
                            {"mean_reach_m", reach},      {"partial_step_share", partial}};
    const std::string line = training_window_line(p);
    char want[256];
    std::snprintf(want, sizeof want, "narrowed training %.0f %% of the time, to %.0f of %.0f candidate keyframes",
                  100 * narrowed, kf, cell);
    EXPECT_NE(line.find(want), std::string::npos) << line;
    std::snprintf(want, sizeof want, "(%.0f m around the latest); %.1f %% of the steps", reach, 100 * partial);
    EXPECT_NE(line.find(want), std::string::npos) << line;
    EXPECT_NE(line.find("--budget"), std::string::npos) << line;
  }
}

TEST(TrainingWindowLine, NothingWhenTrainingWasNeverNarrowed) {
  EXPECT_EQ(training_window_line(nlohmann::json::object()), "");
  nlohmann::json p;
  p["training_window"] = {{"narrowed_share", 0.0}, {"mean_keyframes", 0.0}, {"mean_cell_keyframes", 0.0}};
  EXPECT_EQ(training_window_line(p), "");
}

TEST(PacingLine, NamesWhatBoundsTheStepsAndGivesRatesOnlyOverAChunkOfTravel) {
  nlohmann::json r;
  r["pacing"] = {{"steps_per_keyframe_mean", 42.26},  {"steps_per_keyframe_lowest_minute", 31.5},
                 {"min_steps_per_keyframe", 12},      {"dropped_keyframes", 3},
                 {"checkpoint_share", 0.0071},        {"path_m", 250.0},
                 {"sampled", 5000},                   {"pruned", 1200},
                 {"sampled_per_100m", 2000.0},        {"pruned_per_100m", 480.0}};
  r["settings"] = {{"pacing", "anytime"}, {"iterations_per_keyframe", 30}};
  r["time"] = {{"io_wait_share", 0.0123}};
  EXPECT_EQ(pacing_line(r),
            "pacing: 42.3 steps per keyframe (lowest minute 31.5, floor 12), 3 keyframes dropped, checkpoints 0.71 % "
            "of the time, I/O wait 1.23 %; per 100 m: 2000 Gaussians sampled, 480 pruned");
  r["settings"]["pacing"] = "fixed";
  r["pacing"]["path_m"] = 0.02;
  const std::string still = pacing_line(r);
  EXPECT_NE(still.find("(lowest minute 31.5, fixed at 30)"), std::string::npos) << still;
  EXPECT_NE(still.find("; 5000 Gaussians sampled, 1200 pruned over 0.02 m"), std::string::npos) << still;
  EXPECT_EQ(still.find("per 100 m"), std::string::npos) << still;
}

}  // namespace
}  // namespace chungs
