// The points of `diskchungs pareto`: the settings given on the command line, the folder each point
// maps into, the row each finished run's report gives, and the table, CSV and JSON made of the rows.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "chungs/pipeline/pareto_plot.hpp"

namespace chungs::app {

struct ParetoSetting {
  bool anytime = false;
  int iterations = 0;  // fixed pacing: optimisation steps per keyframe
  double speed = 0;    // anytime pacing: intake rate factor on the dataset's frame rate
  std::string folder() const;    // fixed-N or anytime-S, under --out
  std::string describe() const;  // "fixed 100 steps per keyframe", "anytime 0.5x speed"
};

// "10,30,100" into the fixed points and "0.5,1,2" into the anytime ones; "none" gives no points of
// that kind. Throws Error naming the flag and the entry for an empty list or entry, a value that is
// no number or out of range (steps 0 or more, speeds positive) and an entry given twice.
std::vector<ParetoSetting> parse_pareto_settings(const std::string& iterations, const std::string& speeds);

// A point's row from its run's report: FPS, times, quality on held-out frames and keyframes (LPIPS
// null with the reason where the run had no weights), steps per keyframe, Gaussians.
nlohmann::json pareto_row(const ParetoSetting& s, const nlohmann::json& report);

std::string pareto_csv(const std::vector<nlohmann::json>& rows);
std::string pareto_table(const std::vector<nlohmann::json>& rows);  // aligned columns for the terminal
ParetoPoint pareto_plot_point(const nlohmann::json& row);

}  // namespace chungs::app
