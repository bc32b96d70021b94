#include "chungs/mapping/timeline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "chungs/image/image_io.hpp"

namespace chungs {

std::string timeline_csv(const std::vector<TimelineSample>& samples) {
  std::ostringstream s;
  s << "seconds,frame,keyframes,iterations,resident_gaussians,total_gaussians,chunks,rss_mb,chunk_loads,chunk_saves,"
       "chunk_io_ms,read_mb,written_mb,io_wait_ms,disk_mb\n";
  for (const auto& t : samples)
    s << t.seconds << ',' << t.frame << ',' << t.keyframes << ',' << t.iterations << ',' << t.resident << ','
      << t.total << ',' << t.chunks << ',' << t.rss_mb << ',' << t.loads << ',' << t.saves << ',' << t.io_ms << ','
      << t.read_mb << ',' << t.written_mb << ',' << t.wait_ms << ',' << t.disk_mb << '\n';
  return s.str();
}

nlohmann::json to_json(const std::vector<TimelineSample>& samples) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& t : samples)
    a.push_back({t.seconds, t.frame, t.keyframes, t.iterations, t.resident, t.total, t.chunks, t.rss_mb, t.loads,
                 t.saves, t.io_ms, t.read_mb, t.written_mb, t.wait_ms, t.disk_mb});
  return a;
}

std::vector<TimelineSample> timeline_from_json(const nlohmann::json& j) {
  std::vector<TimelineSample> out;
  if (!j.is_array()) return out;
  for (const auto& r : j) {
    // 11 fields: written before the I/O columns existed (a map resumed from an older version).
    if (!r.is_array() || (r.size() != 11 && r.size() != 15))
      fail("timeline: a sample must have 15 (or 11) fields, got ", r.dump());
    TimelineSample t;
    t.seconds = r[0];
    t.frame = r[1];
    t.keyframes = r[2];
    t.iterations = r[3];
    t.resident = r[4];
    t.total = r[5];
    t.chunks = r[6];
    t.rss_mb = r[7];
    t.loads = r[8];
    t.saves = r[9];
    t.io_ms = r[10];
    if (r.size() == 15) {
      t.read_mb = r[11];
      t.written_mb = r[12];
      t.wait_ms = r[13];
      t.disk_mb = r[14];
    }
    out.push_back(t);
  }
  return out;
}

namespace {

// A 3x5 bitmap font for the plot's labels (digits, the capitals used, a few signs).
const std::map<char, const char*>& font() {
  static const std::map<char, const char*> f = {
      {'0', "####.##.##.####"}, {'1', ".#.##..#..#.###"}, {'2', "###..#####..###"}, {'3', "###..####..####"},
      {'4', "#.##.####..#..#"}, {'5', "####..###..####"}, {'6', "####..####.####"}, {'7', "###..#..#..#..#"},
      {'8', "####.#####.####"}, {'9', "####.####..####"}, {'A', ".#.#.#####.##.#"}, {'B', "##.#.###.#.###."},
      {'C', "####..#..#..###"}, {'D', "##.#.##.##.###."}, {'E', "####..####..###"}, {'F', "####..####..#.."},
      {'G', "####..#.##.####"}, {'H', "#.##.#####.##.#"}, {'I', "###.#..#..#.###"}, {'K', "#.##.###.#.##.#"},
      {'L', "#..#..#..#..###"}, {'M', "#.#####.##.##.#"}, {'N', "##.#.##.##.##.#"}, {'O', "####.##.##.####"},
      {'P', "####.#####..#.."}, {'R', "##.#.###.#.##.#"}, {'S', "####..###..####"}, {'T', "###.#..#..#..#."},
      {'U', "#.##.##.##.####"}, {'Y', "#.##.#.#..#..#."}, {'.', ".............#."}, {'-', "......###......"},
      {'(', ".#.#..#..#...#."}, {')', ".#...#..#..#.#."}, {'/', "..#..#.#.#..#.."}, {' ', "..............."}};
  return f;
}

struct Canvas {
  Image8 img;
  void px(int x, int y, const uint8_t* c) {
    if (x < 0 || y < 0 || x >= img.width() || y >= img.height()) return;
    for (int k = 0; k < 3; ++k) img(x, y, k) = c[k];
  }
  void line(double x0, double y0, double x1, double y1, const uint8_t* c, int thick = 2, int dash = 0) {
    const int n = int(std::max(std::abs(x1 - x0), std::abs(y1 - y0))) + 1;
    for (int i = 0; i <= n; ++i) {
      const double t = double(i) / n;
      const int x = int(std::lround(x0 + t * (x1 - x0))), y = int(std::lround(y0 + t * (y1 - y0)));
      // Dashes by column, so a polyline of many short segments still reads as dashed.
      if (dash && (x / dash) % 2) continue;
      for (int dy = 0; dy < thick; ++dy)
        for (int dx = 0; dx < thick; ++dx) px(x + dx, y + dy, c);
    }
  }
  void text(int x, int y, const std::string& s, const uint8_t* c, int scale = 2) {
    for (char ch : s) {
      auto it = font().find(char(std::toupper(static_cast<unsigned char>(ch))));
      const char* g = it == font().end() ? font().at(' ') : it->second;
      const size_t len = std::char_traits<char>::length(g);
      for (int r = 0; r < 5; ++r)
        for (int q = 0; q < 3; ++q) {
          const size_t k = size_t(r * 3 + q);
          if (k < len && g[k] == '#')
            for (int dy = 0; dy < scale; ++dy)
              for (int dx = 0; dx < scale; ++dx) px(x + q * scale + dx, y + r * scale + dy, c);
        }
      x += 4 * scale;
    }
  }
};

// Axis from 0 to a multiple of a round step (1, 2, 2.5 or 5 times a power of ten) with at most six
// intervals, ending at the first multiple at or above v: 105 keyframes end at 120, not at 200.
struct Axis {
  double step = 1, end = 1;
  int ticks = 1;
};

Axis axis_for(double v) {
  if (!(v > 0)) v = 1;
  const double target = v / 6.0, p = std::pow(10.0, std::floor(std::log10(target)));
  Axis a;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * p >= target * (1 - 1e-12)) {
      a.step = m * p;
      break;
    }
  a.ticks = std::max(1, int(std::ceil(v / a.step - 1e-9)));
  a.end = a.ticks * a.step;
  return a;
}

std::string tick_label(double v) {
  char buf[32];
  if (v == std::floor(v)) std::snprintf(buf, sizeof buf, "%.0f", v);
  else std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

void write_timeline_plot(const std::filesystem::path& file, const std::vector<TimelineSample>& samples, uint64_t budget) {
  const int W = 900, H = 420, L = 80, R = 80, T = 50, B = 50;
  Canvas cv{Image8(W, H, 3, 255)};
  const uint8_t black[3] = {0, 0, 0}, grey[3] = {170, 170, 170}, blue[3] = {30, 80, 220}, red[3] = {220, 40, 40},
                green[3] = {20, 150, 60};
  double max_x = 1, max_g = 0, max_rss = 1;
  for (const auto& s : samples) {
    max_x = std::max(max_x, double(s.keyframes));
    max_g = std::max({max_g, double(s.total), double(s.resident)});
    max_rss = std::max(max_rss, s.rss_mb);
  }
  // The budget line is drawn when it is near the data; a budget far above would flatten the curves.
  const bool show_budget = budget > 0 && double(budget) <= 1.5 * std::max(max_g, 1.0);
  if (show_budget) max_g = std::max(max_g, double(budget));
  const Axis ax = axis_for(max_x), ag = axis_for(std::max(max_g, 1.0) / 1000.0), ar = axis_for(max_rss);
  const double pw = W - L - R, ph = H - T - B;
  auto X = [&](double v) { return L + v / ax.end * pw; };
  auto YG = [&](double v) { return T + ph - v / 1000.0 / ag.end * ph; };
  auto YR = [&](double v) { return T + ph - v / ar.end * ph; };
  cv.line(L, T, L, T + ph, black, 1);
  cv.line(L, T + ph, L + pw, T + ph, black, 1);
  cv.line(L + pw, T, L + pw, T + ph, black, 1);
  for (int i = 0; i <= ag.ticks; ++i) {
    const double y = YG(i * ag.step * 1000.0);
    const std::string l = tick_label(i * ag.step);
    cv.line(L - 5, y, L, y, black, 1);
    cv.text(L - 10 - int(l.size()) * 8, int(y) - 5, l, black);
  }
  for (int i = 0; i <= ar.ticks; ++i) {
    const double y = YR(i * ar.step);
    cv.line(L + pw, y, L + pw + 5, y, black, 1);
    cv.text(int(L + pw) + 10, int(y) - 5, tick_label(i * ar.step), black);
  }
  for (int i = 0; i <= ax.ticks; ++i) {
    const double x = X(i * ax.step);
    const std::string l = tick_label(i * ax.step);
    cv.line(x, T + ph, x, T + ph + 5, black, 1);
    cv.text(int(x) - int(l.size()) * 4, int(T + ph) + 10, l, black);
  }
  cv.text(L + int(pw) / 2 - 40, H - 20, "KEYFRAMES", black);
  cv.text(8, 12, "GAUSSIANS (K)", black);
  cv.text(W - 90, 12, "RSS (MB)", black);
  if (show_budget) cv.line(L, YG(double(budget)), L + pw, YG(double(budget)), grey, 1, 6);
  // Resident first, total over it dashed: while nothing is evicted the two coincide and both show.
  for (size_t i = 1; i < samples.size(); ++i) {
    const auto &a = samples[i - 1], &b = samples[i];
    cv.line(X(double(a.keyframes)), YG(double(a.resident)), X(double(b.keyframes)), YG(double(b.resident)), red, 3);
    cv.line(X(double(a.keyframes)), YR(a.rss_mb), X(double(b.keyframes)), YR(b.rss_mb), green);
  }
  for (size_t i = 1; i < samples.size(); ++i) {
    const auto &a = samples[i - 1], &b = samples[i];
    cv.line(X(double(a.keyframes)), YG(double(a.total)), X(double(b.keyframes)), YG(double(b.total)), blue, 2, 5);
  }
  // The legend is one row in the top margin, so no curve can pass under it.
  int lx = L + 20;
  const int ly = 28;
  auto legend = [&](const uint8_t* c, const std::string& s, int dash = 0) {
    cv.line(lx, ly + 4, lx + 24, ly + 4, c, 2, dash);
    cv.text(lx + 30, ly, s, black);
    lx += 30 + int(s.size()) * 8 + 20;
  };
  legend(blue, "TOTAL GAUSSIANS", 5);
  legend(red, "RESIDENT GAUSSIANS");
  legend(green, "RSS MB");
  legend(grey, show_budget ? "BUDGET" : "BUDGET " + std::to_string(budget) + " (OFF SCALE)");
  write_png(file, cv.img);
}

}  // namespace chungs
