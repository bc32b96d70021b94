#include "chungs/eval/plot_canvas.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>

namespace chungs {
namespace {

// Rows top to bottom: digits, capitals, the signs the labels use.
const std::map<char, const char*>& font() {
  static const std::map<char, const char*> f = {
      {'0', "####.##.##.####"}, {'1', ".#.##..#..#.###"}, {'2', "###..#####..###"}, {'3', "###..####..####"},
      {'4', "#.##.####..#..#"}, {'5', "####..###..####"}, {'6', "####..####.####"}, {'7', "###..#..#..#..#"},
      {'8', "####.#####.####"}, {'9', "####.####..####"}, {'A', ".#.#.#####.##.#"}, {'B', "##.#.###.#.###."},
      {'C', "####..#..#..###"}, {'D', "##.#.##.##.###."}, {'E', "####..####..###"}, {'F', "####..####..#.."},
      {'G', "####..#.##.####"}, {'H', "#.##.#####.##.#"}, {'I', "###.#..#..#.###"}, {'J', "..#..#..##.####"},
      {'K', "#.##.###.#.##.#"}, {'L', "#..#..#..#..###"}, {'M', "#.########.##.#"}, {'N', "##.#.##.##.##.#"},
      {'O', "####.##.##.####"}, {'P', "####.#####..#.."}, {'Q', ".#.#.##.###..##"}, {'R', "##.#.###.#.##.#"},
      {'S', "####..###..####"}, {'T', "###.#..#..#..#."}, {'U', "#.##.##.##.####"}, {'V', "#.##.##.##.#.#."},
      {'W', "#.##.########.#"}, {'X', "#.##.#.#.#.##.#"}, {'Y', "#.##.#.#..#..#."}, {'Z', "###..#.#.#..###"},
      {'.', ".............#."}, {'-', "......###......"}, {'(', ".#.#..#..#...#."}, {')', ".#...#..#..#.#."},
      {'/', "..#..#.#.#..#.."}, {'%', "#....#.#.#....#"}, {':', "....#.....#...."}, {',', "..........#.#.."},
      {'+', "....#.###.#...."}, {'=', "...###...###..."}, {' ', "..............."}};
  return f;
}

}  // namespace

void PlotCanvas::px(int x, int y, const PlotRgb& c) {
  if (x < std::max(0, clip.x0) || y < std::max(0, clip.y0) || x >= img.width() || y >= img.height() ||
      x > clip.x1 || y > clip.y1)
    return;
  for (int k = 0; k < 3; ++k) img(x, y, k) = c[size_t(k)];
}

void PlotCanvas::line(double x0, double y0, double x1, double y1, const PlotRgb& c, int thick, int dash,
                      double* path) {
  const int n = int(std::max(std::abs(x1 - x0), std::abs(y1 - y0))) + 1;
  const double len = std::hypot(x1 - x0, y1 - y0), start = path ? *path : 0;
  if (path) *path += len;
  for (int i = 0; i <= n; ++i) {
    const double t = double(i) / n;
    const int x = int(std::lround(x0 + t * (x1 - x0))), y = int(std::lround(y0 + t * (y1 - y0)));
    if (dash && int((start + t * len) / dash) % 2) continue;
    for (int dy = 0; dy < thick; ++dy)
      for (int dx = 0; dx < thick; ++dx) px(x + dx - (thick - 1) / 2, y + dy - (thick - 1) / 2, c);
  }
}

void PlotCanvas::text(int x, int y, const std::string& s, const PlotRgb& c) {
  for (char ch : s) {
    auto it = font().find(char(std::toupper(static_cast<unsigned char>(ch))));
    const char* g = it == font().end() ? font().at(' ') : it->second;
    for (int r = 0; r < 5; ++r)
      for (int q = 0; q < 3; ++q)
        if (g[r * 3 + q] == '#')
          for (int dy = 0; dy < kPlotTextScale; ++dy)
            for (int dx = 0; dx < kPlotTextScale; ++dx)
              px(x + q * kPlotTextScale + dx, y + r * kPlotTextScale + dy, c);
    x += kPlotTextAdvance;
  }
}

PlotAxis plot_axis(double max) { return plot_axis(0, max); }

PlotAxis plot_axis(double lo, double hi) {
  if (!std::isfinite(lo)) lo = 0;
  if (!(hi > lo)) hi = lo + (lo == 0 ? 1 : std::abs(lo) * 0.1);
  const double target = (hi - lo) / 6.0, p = std::pow(10.0, std::floor(std::log10(target)));
  PlotAxis a;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * p >= target * (1 - 1e-12)) {
      a.step = m * p;
      break;
    }
  a.start = lo == 0 ? 0 : std::floor(lo / a.step + 1e-9) * a.step;
  a.ticks = std::max(1, int(std::ceil((hi - a.start) / a.step - 1e-9)));
  a.end = a.start + a.ticks * a.step;
  return a;
}

std::string plot_number(double v) {
  char buf[32];
  if (std::abs(v - std::round(v)) < 1e-9 * std::max(1.0, std::abs(v)))
    std::snprintf(buf, sizeof buf, "%.0f", v);
  else
    std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace chungs
