// The run summary's line on the training window: the report's figures, and nothing without narrowing.
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

}  // namespace
}  // namespace chungs
