// Drawing on an RGB bitmap for the plots a run writes (memory.png, pareto.png): lines, dashes and
// text in a 3x5 font of its own, so the mapper needs no plotting library.
#pragma once
#include <array>
#include <cstdint>
#include <string>

#include "chungs/image/image.hpp"

namespace chungs {

using PlotRgb = std::array<uint8_t, 3>;

// Text is the font's cells doubled: 8 pixels a character across, 10 high.
constexpr int kPlotTextScale = 2, kPlotTextAdvance = 4 * kPlotTextScale, kPlotTextHeight = 5 * kPlotTextScale;

// Pixels, inclusive on all sides.
struct PlotBox {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

struct PlotCanvas {
  Image8 img;
  PlotBox clip{0, 0, 1 << 30, 1 << 30};  // curves stay inside their panel

  void clip_to(const PlotBox& box) { clip = box; }
  void unclip() { clip = {0, 0, 1 << 30, 1 << 30}; }
  void px(int x, int y, const PlotRgb& c);
  // dash > 0: on and off runs of that many pixels along the path; `path` carries the distance
  // drawn so far from one segment to the next, so a polyline of many short (or steep) segments still
  // reads as dashed.
  void line(double x0, double y0, double x1, double y1, const PlotRgb& c, int thick = 2, int dash = 0,
            double* path = nullptr);
  // Capitals only: lower case is drawn as upper case, characters the font lacks as blanks.
  void text(int x, int y, const std::string& s, const PlotRgb& c);
  static int width(const std::string& s) { return int(s.size()) * kPlotTextAdvance; }
};

// An axis from `start` in `ticks` round steps (1, 2, 2.5 or 5 times a power of ten, at most about
// six intervals) to the first multiple at or above the largest value: 105 keyframes end at 120, not
// at 200.
struct PlotAxis {
  double start = 0, step = 1, end = 1;
  int ticks = 1;
};
PlotAxis plot_axis(double max);  // from 0
// From the last multiple of the step at or below `lo`: quality values sit far above zero.
PlotAxis plot_axis(double lo, double hi);

// A tick label: whole numbers without decimals, others as %g.
std::string plot_number(double v);

}  // namespace chungs
