// memory.png: four panels against time sharing one x axis, drawn on a plot canvas (plot_canvas.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "chungs/image/image_io.hpp"
#include "chungs/pipeline/pacing_summary.hpp"
#include "chungs/eval/plot_canvas.hpp"
#include "chungs/pipeline/timeline.hpp"

namespace chungs {
namespace {

const PlotRgb kBlack{0, 0, 0}, kGrid{232, 232, 232}, kBudget{150, 150, 150}, kTotal{30, 80, 220},
    kResident{220, 40, 40}, kOnDisk{240, 140, 0}, kRss{20, 150, 60}, kVram{140, 50, 180}, kLoads{0, 160, 170},
    kSaves{220, 60, 170}, kDisk{170, 140, 0}, kSteps{60, 60, 60};

PlotBox plot_box(const TimelinePlotBox& b) { return {b.x0, b.y0, b.x1, b.y1}; }

// A count's display unit, chosen so the axis labels stay short: none, thousands or millions.
struct Unit {
  double div = 1;
  std::string name;
};
Unit count_unit(double max) {
  if (max >= 1e6) return {1e6, "M"};
  if (max >= 1e3) return {1e3, "K"};
  return {1, ""};
}

// One panel: a plot box with a left value axis (and optionally a right one) under a title row and a
// legend row, so no curve passes under the legend.
struct Panel {
  PlotCanvas& cv;
  const std::vector<TimelineSample>& samples;
  TimelinePlotBox box;
  PlotAxis x;
  double t_div = 1;  // seconds per x unit
  PlotAxis left;
  double left_div = 1;  // sample units per left axis unit
  PlotAxis right{};
  double right_div = 1;
  int legend_x = 0;

  double X(double t) const { return box.x0 + t / x.end * (box.x1 - box.x0); }
  double Y(const PlotAxis& a, double v) const { return box.y1 - v / a.end * (box.y1 - box.y0); }

  void frame(bool x_labels, bool right_axis) {
    for (int i = 1; i <= left.ticks; ++i)
      cv.line(box.x0, Y(left, i * left.step), box.x1, Y(left, i * left.step), kGrid, 1);
    for (int i = 1; i <= x.ticks; ++i) cv.line(X(i * x.step), box.y0, X(i * x.step), box.y1, kGrid, 1);
    cv.line(box.x0, box.y0, box.x0, box.y1, kBlack, 1);
    cv.line(box.x0, box.y1, box.x1, box.y1, kBlack, 1);
    cv.line(box.x1, box.y0, box.x1, box.y1, kBlack, 1);
    cv.line(box.x0, box.y0, box.x1, box.y0, kBlack, 1);
    for (int i = 0; i <= left.ticks; ++i) {
      const double y = Y(left, i * left.step);
      const std::string l = plot_number(i * left.step);
      cv.line(box.x0 - 5, y, box.x0, y, kBlack, 1);
      cv.text(box.x0 - 9 - PlotCanvas::width(l), int(y) - kPlotTextHeight / 2, l, kBlack);
    }
    if (right_axis)
      for (int i = 0; i <= right.ticks; ++i) {
        const double y = Y(right, i * right.step);
        cv.line(box.x1, y, box.x1 + 5, y, kBlack, 1);
        cv.text(box.x1 + 9, int(y) - kPlotTextHeight / 2, plot_number(i * right.step), kBlack);
      }
    for (int i = 0; i <= x.ticks; ++i) {
      const double px = X(i * x.step);
      cv.line(px, box.y1, px, box.y1 + 5, kBlack, 1);
      const std::string l = plot_number(i * x.step);
      if (x_labels) cv.text(int(px) - PlotCanvas::width(l) / 2, box.y1 + 10, l, kBlack);
    }
    legend_x = box.x0;
  }
  void title(const std::string& s, const std::string& right_label = "") {
    cv.text(box.x0 - 60, box.y0 - 42, s, kBlack);
    if (!right_label.empty())
      cv.text(box.x1 + 60 - PlotCanvas::width(right_label), box.y0 - 42, right_label, kBlack);
  }
  void legend(const PlotRgb& c, const std::string& s, int dash = 0) {
    const int y = box.y0 - 22;
    cv.line(legend_x, y + kPlotTextHeight / 2, legend_x + 24, y + kPlotTextHeight / 2, c, 3, dash);
    cv.text(legend_x + 30, y, s, kBlack);
    legend_x += 30 + PlotCanvas::width(s) + 24;
  }
  // One curve against the left or the right axis.
  void curve(bool on_right, double (*value)(const TimelineSample&), const PlotRgb& c, int thick, int dash = 0) {
    const PlotAxis& a = on_right ? right : left;
    const double div = on_right ? right_div : left_div;
    cv.clip_to(plot_box(box));
    auto point = [&](const TimelineSample& s) {
      return std::pair{X(s.seconds / t_div), Y(a, value(s) / div)};
    };
    double path = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
      const auto [x0, y0] = point(samples[i == 0 ? 0 : i - 1]);
      const auto [x1, y1] = point(samples[i]);
      // A value that is not finite (never written by the mapper) is left out rather than drawn.
      if (!std::isfinite(x0 + y0 + x1 + y1)) continue;
      if (i > 0 || samples.size() == 1) cv.line(x0, y0, x1, y1, c, thick, dash, &path);
    }
    cv.unclip();
  }
};

double total(const TimelineSample& s) { return double(s.total); }
double resident(const TimelineSample& s) { return double(s.resident); }
double on_disk(const TimelineSample& s) { return double(s.total - std::min(s.total, s.resident)); }
double rss(const TimelineSample& s) { return s.rss_mb; }
double vram(const TimelineSample& s) { return s.vram_mb; }
double loads(const TimelineSample& s) { return double(s.loads); }
double saves(const TimelineSample& s) { return double(s.saves); }
double disk(const TimelineSample& s) { return s.disk_mb; }
double steps(const TimelineSample& s) { return double(s.iterations); }

constexpr int kW = 1000, kH = 1002, kL = 90, kR = 90, kTop = 52, kPlotH = 174, kGap = 68;

}  // namespace

TimelinePlotLayout timeline_plot_layout() {
  TimelinePlotLayout l;
  l.width = kW;
  l.height = kH;
  TimelinePlotBox* boxes[4] = {&l.gaussians, &l.memory, &l.io, &l.steps};
  for (int i = 0; i < 4; ++i) {
    const int y0 = kTop + i * (kPlotH + kGap);
    *boxes[i] = {kL, y0, kW - kR, y0 + kPlotH};
  }
  return l;
}

void write_timeline_plot(const std::filesystem::path& file, const std::vector<TimelineSample>& samples,
                         uint64_t budget, uint64_t refinement_steps) {
  PlotCanvas cv{Image8(kW, kH, 3, 255)};
  const TimelinePlotLayout lay = timeline_plot_layout();
  double max_t = 0, max_g = 0, max_mem = 1, max_io = 0, max_disk = 0;
  bool any_vram = false;
  for (const auto& s : samples) {
    max_t = std::max(max_t, s.seconds);
    max_g = std::max({max_g, double(s.total), double(s.resident)});
    max_mem = std::max({max_mem, s.rss_mb, s.vram_mb});
    max_io = std::max({max_io, double(s.loads), double(s.saves)});
    max_disk = std::max(max_disk, s.disk_mb);
    any_vram = any_vram || s.vram_mb > 0;
  }
  // Minutes past three minutes: a long run read in seconds needs mental arithmetic at every tick.
  const bool minutes = max_t > 180;
  const double t_div = minutes ? 60 : 1;
  const PlotAxis ax = plot_axis(max_t / t_div);

  // Gaussians. The budget line is drawn when it is near the data; a budget far above would flatten
  // the curves, so the legend names it as off scale instead.
  const bool show_budget = budget > 0 && double(budget) <= 1.5 * std::max(max_g, 1.0);
  const double g_top = std::max(max_g, show_budget ? double(budget) : 0.0);
  const Unit gu = count_unit(g_top);
  Panel g{cv, samples, lay.gaussians, ax, t_div, plot_axis(g_top / gu.div), gu.div};
  g.frame(false, false);
  g.title("GAUSSIANS" + (gu.name.empty() ? std::string() : " (" + gu.name + ")"));
  if (show_budget) {
    const double y = g.Y(g.left, double(budget) / gu.div);
    cv.clip_to(plot_box(g.box));
    cv.line(g.box.x0, y, g.box.x1, y, kBudget, 2, 8);
    cv.unclip();
  }
  // On disk and resident first, total over them dashed and thinner: while nothing is evicted resident
  // and total coincide, and the resident line's top row still shows (also at 0, where the box clips
  // its bottom row).
  g.curve(false, on_disk, kOnDisk, 3);
  g.curve(false, resident, kResident, 3);
  g.curve(false, total, kTotal, 2, 6);
  g.legend(kTotal, "TOTAL", 6);
  g.legend(kResident, "RESIDENT");
  g.legend(kOnDisk, "ON DISK");
  const Unit bu = count_unit(double(budget));
  const std::string bl = "BUDGET " + plot_number(double(budget) / bu.div) + bu.name;
  g.legend(kBudget, show_budget ? bl : bl + " (OFF SCALE)", 8);

  // Memory.
  Panel m{cv, samples, lay.memory, ax, t_div, plot_axis(max_mem), 1};
  m.frame(false, false);
  m.title("MEMORY (MB)");
  m.curve(false, rss, kRss, 3);
  m.legend(kRss, "HOST RSS");
  if (any_vram) {
    m.curve(false, vram, kVram, 3);
    m.legend(kVram, "VRAM");
  }

  // Chunk I/O: counts on the left, the map folder's size on the right.
  const Unit iu = count_unit(max_io);
  const bool gb = max_disk >= 1024;
  const double disk_div = gb ? 1024 : 1;
  Panel io{
      cv,      samples, lay.io, ax, t_div, plot_axis(max_io / iu.div), iu.div, plot_axis(max_disk / disk_div),
      disk_div};
  io.frame(false, true);
  std::string title = "CHUNKS LOADED/SAVED" + (iu.name.empty() ? std::string() : " (" + iu.name + ")");
  if (!samples.empty() && samples.back().seconds > 0) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "   OPTIMISER WAITED ON I/O %.1f%% OF THE TIME",
                  100.0 * samples.back().wait_ms / (samples.back().seconds * 1000.0));
    title += buf;
  }
  io.title(title, gb ? "DISK (GB)" : "DISK (MB)");
  io.curve(true, disk, kDisk, 3);
  io.curve(false, saves, kSaves, 3);
  io.curve(false, loads, kLoads, 3);
  io.legend(kLoads, "CHUNK LOADS");
  io.legend(kSaves, "CHUNK SAVES");
  io.legend(kDisk, "MAP FOLDER ON DISK (RIGHT AXIS)");

  // Steps per keyframe: whether the optimiser kept up with the intake. One point per keyframe (the
  // `iterations` field of these derived samples holds the steps it got).
  const PacingSummary pace = pacing_summary(samples, refinement_steps);
  std::vector<TimelineSample> per_kf;
  double max_steps = 1;
  for (const auto& [t, n] : pace.per_keyframe) {
    TimelineSample d;
    d.seconds = t;
    d.iterations = n;
    per_kf.push_back(d);
    max_steps = std::max(max_steps, double(n));
  }
  // Headroom above the largest value, so a constant count (fixed pacing) does not hide in the frame.
  Panel st{cv, per_kf, lay.steps, ax, t_div, plot_axis(max_steps * 1.15), 1};
  st.frame(true, false);
  char buf[160], ck[64];
  std::snprintf(buf, sizeof buf, "STEPS PER KEYFRAME: MEAN %.1f, LOWEST MINUTE %.1f   %llu KEYFRAMES DROPPED",
                pace.steps_mean, pace.steps_lowest_minute, (unsigned long long)pace.dropped);
  std::snprintf(ck, sizeof ck, "CHECKPOINTS %.2f%% OF THE TIME", 100.0 * pace.checkpoint_share);
  st.title(buf, ck);
  st.curve(false, steps, kSteps, 2);
  st.legend(kSteps, "STEPS EACH KEYFRAME GOT");

  const std::string xl = minutes ? "TIME (MIN)" : "TIME (S)";
  cv.text((lay.steps.x0 + lay.steps.x1 - PlotCanvas::width(xl)) / 2, lay.steps.y1 + 32, xl, kBlack);
  write_png(file, cv.img);
}

}  // namespace chungs
