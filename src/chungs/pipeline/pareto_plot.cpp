#include "chungs/pipeline/pareto_plot.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "chungs/image/image_io.hpp"

namespace chungs {
namespace {

const PlotRgb kBlack{0, 0, 0}, kGrid{232, 232, 232}, kKey{90, 90, 90};
constexpr int kL = 90, kR = 40, kTop = 60, kPlotH = 220, kGap = 76, kDash = 7;
static_assert(kTop + 3 * kPlotH + 2 * kGap + 60 == kParetoPlotHeight);

// Ticks at 1, 2 and 5 times the powers of ten in [lo, hi]; denser where the range is narrow (a
// factor of two), only the powers where it is wide, so the axis keeps three to ten labels.
std::vector<double> log_ticks(double lo, double hi) {
  const std::vector<std::vector<double>> sets = {{1, 2, 5}, {1, 1.5, 2, 3, 4, 5, 6, 8}, {1}};
  std::vector<double> best;
  for (const auto& set : sets) {
    std::vector<double> t;
    for (int e = int(std::floor(std::log10(lo))) - 1; e <= int(std::ceil(std::log10(hi))); ++e)
      for (double m : set) {
        const double v = m * std::pow(10.0, e);
        if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) t.push_back(v);
      }
    if (t.size() >= 3 && t.size() <= 10) return t;
    if (best.empty() || (best.size() > 10 && t.size() < best.size())) best = t;
  }
  return best;
}

struct Panel {
  PlotCanvas& cv;
  PlotBox box;
  double log_lo = 0, log_hi = 1;
  PlotAxis y;

  double X(double fps) const { return box.x0 + (std::log10(fps) - log_lo) / (log_hi - log_lo) * (box.x1 - box.x0); }
  double Y(double v) const { return box.y1 - (v - y.start) / (y.end - y.start) * (box.y1 - box.y0); }

  void frame(const std::vector<double>& x_ticks, bool y_labels) {
    if (y_labels)
      for (int i = 0; i <= y.ticks; ++i) {
        const double v = y.start + i * y.step, py = Y(v);
        cv.line(box.x0, py, box.x1, py, kGrid, 1);
        cv.line(box.x0 - 5, py, box.x0, py, kBlack, 1);
        const std::string l = plot_number(v);
        cv.text(box.x0 - 9 - PlotCanvas::width(l), int(py) - kPlotTextHeight / 2, l, kBlack);
      }
    for (double t : x_ticks) {
      const double px = X(t);
      cv.line(px, box.y0, px, box.y1, kGrid, 1);
      cv.line(px, box.y1, px, box.y1 + 5, kBlack, 1);
      const std::string l = plot_number(t);
      cv.text(int(px) - PlotCanvas::width(l) / 2, box.y1 + 10, l, kBlack);
    }
    cv.line(box.x0, box.y0, box.x0, box.y1, kBlack, 1);
    cv.line(box.x0, box.y1, box.x1, box.y1, kBlack, 1);
    cv.line(box.x1, box.y0, box.x1, box.y1, kBlack, 1);
    cv.line(box.x0, box.y0, box.x1, box.y0, kBlack, 1);
  }

  // One mode's points (sorted by FPS) as a polyline with square marks: filled for held-out frames,
  // hollow for keyframes, whose line is dashed.
  void curve(const std::vector<const ParetoPoint*>& pts, double (*value)(const ParetoPoint&), bool dashed,
             const PlotRgb& c) {
    cv.clip_to(box);
    double path = 0;
    const ParetoPoint* prev = nullptr;
    for (const ParetoPoint* p : pts) {
      const double v = value(*p);
      if (!std::isfinite(v)) continue;
      if (prev) cv.line(X(prev->fps), Y(value(*prev)), X(p->fps), Y(v), c, 2, dashed ? kDash : 0, &path);
      prev = p;
    }
    for (const ParetoPoint* p : pts) {
      const double v = value(*p);
      if (!std::isfinite(v)) continue;
      const int px = int(std::lround(X(p->fps))), py = int(std::lround(Y(v)));
      for (int dy = -3; dy <= 3; ++dy)
        for (int dx = -3; dx <= 3; ++dx)
          if (!dashed || std::abs(dx) == 3 || std::abs(dy) == 3) cv.px(px + dx, py + dy, c);
    }
    cv.unclip();
  }

  // Labels beside the held-out marks, each at the first place around its mark that stays inside the
  // panel and clear of the marks and the labels placed before it: points close in FPS (two intake
  // speeds the CPU cannot tell apart) would otherwise print over each other. Fixed pacing tries above
  // first, anytime below, so that crossing curves keep theirs apart.
  void labels(const std::vector<const ParetoPoint*>& pts, double (*value)(const ParetoPoint&), const PlotRgb& c,
              std::vector<PlotBox>& taken) {
    for (const ParetoPoint* p : pts) {
      const double v = value(*p);
      if (!std::isfinite(v)) continue;
      const int px = int(std::lround(X(p->fps))), py = int(std::lround(Y(v)));
      const int w = PlotCanvas::width(p->label), h = kPlotTextHeight;
      const int above = py - 6 - h, below = py + 6;
      std::vector<int> rows = p->anytime ? std::vector<int>{below, above} : std::vector<int>{above, below};
      for (int k = 1; k <= 3; ++k) {
        rows.push_back(p->anytime ? below + k * (h + 3) : above - k * (h + 3));
        rows.push_back(p->anytime ? above - k * (h + 3) : below + k * (h + 3));
      }
      std::optional<PlotBox> chosen;
      for (int y : rows) {
        for (int x : {px + 7, px - 7 - w}) {
          const PlotBox r{x, y, x + w - 1, y + h - 1};
          if (r.x0 < box.x0 + 2 || r.x1 > box.x1 - 2 || r.y0 < box.y0 + 2 || r.y1 > box.y1 - 2) continue;
          if (std::none_of(taken.begin(), taken.end(), [&](const PlotBox& t) { return overlap(r, t); })) {
            chosen = r;
            break;
          }
        }
        if (chosen) break;
      }
      // Nowhere free: beside the mark all the same, over whatever is there.
      const PlotBox r = chosen.value_or(PlotBox{px + 7, rows[0], px + 6 + w, rows[0] + h - 1});
      taken.push_back({r.x0 - 2, r.y0 - 1, r.x1 + 2, r.y1 + 1});
      cv.text(r.x0, r.y0, p->label, c);
    }
  }

  static bool overlap(const PlotBox& a, const PlotBox& b) {
    return a.x0 <= b.x1 && b.x0 <= a.x1 && a.y0 <= b.y1 && b.y0 <= a.y1;
  }

  // The marks' squares, which labels keep clear of.
  void marks(const std::vector<const ParetoPoint*>& pts, double (*value)(const ParetoPoint&),
             std::vector<PlotBox>& taken) const {
    for (const ParetoPoint* p : pts) {
      const double v = value(*p);
      if (!std::isfinite(v)) continue;
      const int px = int(std::lround(X(p->fps))), py = int(std::lround(Y(v)));
      taken.push_back({px - 4, py - 4, px + 4, py + 4});
    }
  }
};

double nan() { return std::nan(""); }
double held_psnr(const ParetoPoint& p) { return p.held_out.psnr; }
double key_psnr(const ParetoPoint& p) { return p.keyframes.psnr; }
double held_ssim(const ParetoPoint& p) { return p.held_out.ssim; }
double key_ssim(const ParetoPoint& p) { return p.keyframes.ssim; }
double held_lpips(const ParetoPoint& p) { return p.held_out.lpips.value_or(nan()); }
double key_lpips(const ParetoPoint& p) { return p.keyframes.lpips.value_or(nan()); }

struct Metric {
  const char* title;
  double (*held)(const ParetoPoint&);
  double (*key)(const ParetoPoint&);
};

}  // namespace

void write_pareto_plot(const std::filesystem::path& file, const std::vector<ParetoPoint>& points,
                       const std::string& lpips_unavailable) {
  PlotCanvas cv{Image8(kParetoPlotWidth, kParetoPlotHeight, 3, 255)};
  std::vector<const ParetoPoint*> fixed, anytime;
  double lo = 0, hi = 0;
  for (const ParetoPoint& p : points) {
    if (!(std::isfinite(p.fps) && p.fps > 0)) continue;  // no place on a log axis
    (p.anytime ? anytime : fixed).push_back(&p);
    lo = lo > 0 ? std::min(lo, p.fps) : p.fps;
    hi = std::max(hi, p.fps);
  }
  auto by_fps = [](const ParetoPoint* a, const ParetoPoint* b) { return a->fps < b->fps; };
  std::sort(fixed.begin(), fixed.end(), by_fps);
  std::sort(anytime.begin(), anytime.end(), by_fps);
  if (!(lo > 0)) lo = hi = 1;
  // A margin of a quarter of the range (at least a factor 1.25) keeps the end points and their
  // labels off the frame.
  const double margin = std::max(std::log10(1.25), 0.12 * (std::log10(hi) - std::log10(lo)));
  const double log_lo = std::log10(lo) - margin, log_hi = std::log10(hi) + margin;
  const std::vector<double> x_ticks = log_ticks(std::pow(10.0, log_lo), std::pow(10.0, log_hi));

  const Metric metrics[3] = {{"PSNR (DB), HIGHER IS BETTER", held_psnr, key_psnr},
                             {"SSIM, HIGHER IS BETTER", held_ssim, key_ssim},
                             {"LPIPS, LOWER IS BETTER", held_lpips, key_lpips}};
  for (int i = 0; i < 3; ++i) {
    const Metric& m = metrics[i];
    const int y0 = kTop + i * (kPlotH + kGap);
    double vlo = INFINITY, vhi = -INFINITY;
    for (const ParetoPoint* p : fixed)
      for (double v : {m.held(*p), m.key(*p)})
        if (std::isfinite(v)) vlo = std::min(vlo, v), vhi = std::max(vhi, v);
    for (const ParetoPoint* p : anytime)
      for (double v : {m.held(*p), m.key(*p)})
        if (std::isfinite(v)) vlo = std::min(vlo, v), vhi = std::max(vhi, v);
    const bool any = vlo <= vhi;
    // Room above and below the extreme points for their labels.
    const double pad = any ? std::max(0.15 * (vhi - vlo), 1e-3 * std::max(1.0, std::abs(vhi))) : 0;
    Panel panel{cv, {kL, y0, kParetoPlotWidth - kR, y0 + kPlotH}, log_lo, log_hi,
                any ? plot_axis(vlo - pad, vhi + pad) : PlotAxis{}};
    panel.frame(x_ticks, any);
    cv.text(kL - 60, y0 - 42, m.title, kBlack);
    if (!any) {
      const std::string why =
          i == 2 && !lpips_unavailable.empty() ? "LPIPS NOT AVAILABLE: " + lpips_unavailable : "NO VALUES";
      cv.text((panel.box.x0 + panel.box.x1 - PlotCanvas::width(why)) / 2, y0 + kPlotH / 2, why, kBlack);
      continue;
    }
    panel.curve(fixed, m.key, true, kParetoFixed);
    panel.curve(anytime, m.key, true, kParetoAnytime);
    panel.curve(fixed, m.held, false, kParetoFixed);
    panel.curve(anytime, m.held, false, kParetoAnytime);
    std::vector<PlotBox> taken;
    for (const auto* pts : {&fixed, &anytime}) {
      panel.marks(*pts, m.held, taken);
      panel.marks(*pts, m.key, taken);
    }
    panel.labels(fixed, m.held, kParetoFixed, taken);
    panel.labels(anytime, m.held, kParetoAnytime, taken);
    if (i == 0) {
      int x = kL;
      auto legend = [&](const PlotRgb& c, const std::string& s, int dash) {
        const int y = y0 - 22;
        cv.line(x, y + kPlotTextHeight / 2, x + 24, y + kPlotTextHeight / 2, c, 3, dash);
        cv.text(x + 30, y, s, kBlack);
        x += 30 + PlotCanvas::width(s) + 24;
      };
      legend(kParetoFixed, "FIXED PACING: STEPS PER KEYFRAME", 0);
      legend(kParetoAnytime, "ANYTIME PACING: INTAKE SPEED", 0);
      legend(kKey, "HELD-OUT", 0);
      legend(kKey, "KEYFRAMES", kDash);
    }
  }
  const std::string xl = "PROCESSING FPS (LOG SCALE)";
  const int last_y1 = kTop + 3 * kPlotH + 2 * kGap;
  cv.text((kL + kParetoPlotWidth - kR - PlotCanvas::width(xl)) / 2, last_y1 + 32, xl, kBlack);
  write_png(file, cv.img);
}

}  // namespace chungs
