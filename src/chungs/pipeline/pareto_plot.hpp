// pareto.png (`diskchungs pareto`): quality against processing FPS for a dataset mapped at several
// time budgets, like the paper's Figure 1. One curve for fixed pacing (points labelled by the steps
// per keyframe) and one for anytime pacing (labelled by the intake speed); held-out frames solid,
// keyframes dashed; PSNR, SSIM and LPIPS in three panels over one log-scaled FPS axis.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "chungs/eval/plot_canvas.hpp"

namespace chungs {

struct ParetoQuality {
  double psnr = 0, ssim = 0;
  std::optional<double> lpips;  // absent where no weights scored the run: the panel says why instead
};

struct ParetoPoint {
  bool anytime = false;
  std::string label;  // drawn beside the point
  double fps = 0;     // processing FPS: frames mapped per second of mapping
  ParetoQuality held_out, keyframes;
};

// Curves are drawn without anti-aliasing, so tests find them by these exact colours.
inline constexpr PlotRgb kParetoFixed{30, 80, 220}, kParetoAnytime{220, 40, 40};
inline constexpr int kParetoPlotWidth = 1000, kParetoPlotHeight = 932;

// lpips_unavailable: written in the LPIPS panel where no point has an LPIPS value.
void write_pareto_plot(const std::filesystem::path& file, const std::vector<ParetoPoint>& points,
                       const std::string& lpips_unavailable);

}  // namespace chungs
