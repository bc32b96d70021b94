// The memory plot draws each curve in its own panel against time, shows every curve over its whole
// range (the legends sit above the plot areas) and draws VRAM and the budget only when they apply.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>

#include "chungs/image/image_io.hpp"
#include "chungs/pipeline/timeline.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

// The plot's colours (curves are drawn without anti-aliasing, so they match exactly).
using Rgb = std::array<int, 3>;
const Rgb kTotal{30, 80, 220}, kResident{220, 40, 40}, kOnDisk{240, 140, 0}, kBudget{150, 150, 150},
    kRss{20, 150, 60}, kVram{140, 50, 180}, kLoads{0, 160, 170}, kSaves{220, 60, 170}, kDisk{170, 140, 0},
    kSteps{60, 60, 60};

bool is(const Image8& img, int x, int y, const Rgb& c) {
  return img(x, y, 0) == c[0] && img(x, y, 1) == c[1] && img(x, y, 2) == c[2];
}

int count(const Image8& img, const TimelinePlotBox& b, const Rgb& c) {
  int n = 0;
  for (int y = b.y0; y <= b.y1; ++y)
    for (int x = b.x0; x <= b.x1; ++x) n += is(img, x, y, c);
  return n;
}

int count_all(const Image8& img, const Rgb& c) {
  return count(img, {0, 0, img.width() - 1, img.height() - 1}, c);
}

// A 20 minute run: the map grows to 4 M Gaussians, the resident set stays at a 1.5 M budget from
// 30 % on, chunks are loaded and saved at a growing rate and the map folder grows to 3 GB.
std::vector<TimelineSample> long_run(bool with_vram) {
  std::vector<TimelineSample> s;
  const int n = 3000;
  for (int i = 1; i <= n; ++i) {
    const double f = double(i) / n;
    TimelineSample t;
    t.seconds = 1200.0 * f;
    t.keyframes = uint64_t(i);
    t.total = uint64_t(4e6 * f);
    t.resident = std::min<uint64_t>(t.total, 1500000);
    t.rss_mb = 1200 + 30 * std::sin(7 * f);
    t.vram_mb = with_vram ? 5000 + 80 * std::cos(5 * f) : 0;
    const double evicting = std::max(0.0, f - 0.3);
    t.loads = uint64_t(9000 * evicting * evicting);
    t.saves = uint64_t(14000 * evicting * evicting + 300 * f);
    t.disk_mb = 3072 * f;
    t.wait_ms = 0.04 * t.seconds * 1000;
    t.iterations = uint64_t(i) * 20 + (i > 1500 ? uint64_t(i - 1500) * 10 : 0);  // 20, later 30 per keyframe
    s.push_back(t);
  }
  return s;
}

TEST(TimelinePlot, DrawsEachCurveInItsOwnPanel) {
  test::TempDir dir;
  write_timeline_plot(dir / "m.png", long_run(true), 1500000);
  const Image8 img = read_image8(dir / "m.png");
  const TimelinePlotLayout lay = timeline_plot_layout();
  ASSERT_EQ(img.width(), lay.width);
  ASSERT_EQ(img.height(), lay.height);
  const std::vector<TimelinePlotBox> panels = {lay.gaussians, lay.memory, lay.io, lay.steps};
  const std::vector<std::pair<Rgb, int>> curves = {{kTotal, 0},  {kResident, 0}, {kOnDisk, 0}, {kBudget, 0},
                                                   {kRss, 1},    {kVram, 1},     {kLoads, 2},  {kSaves, 2},
                                                   {kDisk, 2},   {kSteps, 3}};
  for (size_t c = 0; c < curves.size(); ++c)
    for (int p = 0; p < 4; ++p) {
      const int n = count(img, panels[size_t(p)], curves[c].first);
      if (p == curves[c].second)
        EXPECT_GT(n, 100) << "curve " << c << " missing from panel " << p;
      else
        EXPECT_EQ(n, 0) << "curve " << c << " drawn in panel " << p;
    }
}

TEST(TimelinePlot, StepsPerKeyframeStepUpWhereTheRunGaveMore) {
  test::TempDir dir;
  write_timeline_plot(dir / "m.png", long_run(false), 1500000);
  const Image8 img = read_image8(dir / "m.png");
  const TimelinePlotBox b = timeline_plot_layout().steps;
  // The curve's row in the first and last tenth: 20 then 30 steps, on an axis from 0 to 40 (the
  // largest value plus headroom, rounded up to a tick).
  auto mean_row = [&](int x0, int x1) {
    double sum = 0;
    int n = 0;
    for (int x = x0; x < x1; ++x)
      for (int y = b.y0 + 1; y < b.y1; ++y)
        if (is(img, x, y, kSteps)) sum += y, ++n;
    return n ? sum / n : -1.0;
  };
  const int w = b.x1 - b.x0;
  const double early = mean_row(b.x0 + 2, b.x0 + w / 10), late = mean_row(b.x1 - w / 10, b.x1 - 2);
  ASSERT_GT(early, 0);
  ASSERT_GT(late, 0);
  EXPECT_NEAR(b.y1 - early, (b.y1 - b.y0) * 20.0 / 40.0, 3.0);
  EXPECT_NEAR(b.y1 - late, (b.y1 - b.y0) * 30.0 / 40.0, 3.0);
}

TEST(TimelinePlot, RunWithoutVramDrawsNoVramColour) {
  test::TempDir dir;
  write_timeline_plot(dir / "cpu.png", long_run(false), 1500000);
  write_timeline_plot(dir / "gpu.png", long_run(true), 1500000);
  EXPECT_EQ(count_all(read_image8(dir / "cpu.png"), kVram), 0);
  EXPECT_GT(count_all(read_image8(dir / "gpu.png"), kVram), 1000);  // curve and legend swatch
}

TEST(TimelinePlot, XAxisIsTimeNotKeyframes) {
  // Keyframes come ever more slowly (seconds grow with their square) while RSS grows linearly with
  // time: against time it is a straight rising line, against keyframes it would bend.
  test::TempDir dir;
  std::vector<TimelineSample> s;
  for (uint64_t k = 1; k <= 100; ++k) {
    TimelineSample t;
    t.keyframes = k;
    t.seconds = 0.02 * double(k * k);
    t.rss_mb = 5 * t.seconds;
    t.total = t.resident = 1000 * k;
    s.push_back(t);
  }
  write_timeline_plot(dir / "m.png", s, 0);
  const Image8 img = read_image8(dir / "m.png");
  const TimelinePlotBox b = timeline_plot_layout().memory;
  std::vector<std::pair<int, double>> centre;  // column, mean row of the RSS curve
  for (int x = b.x0 + 1; x < b.x1; ++x) {
    double sum = 0;
    int n = 0;
    for (int y = b.y0 + 1; y < b.y1; ++y)
      if (is(img, x, y, kRss)) sum += y, ++n;
    if (n) centre.emplace_back(x, sum / n);
  }
  ASSERT_GT(centre.size(), 100u);
  const auto [xa, ya] = centre.front();
  const auto [xb, yb] = centre.back();
  double worst = 0;
  for (size_t i = 1; i < centre.size(); ++i) {
    EXPECT_LE(centre[i].second, centre[i - 1].second + 1.0) << "column " << centre[i].first;
    const double line = ya + (yb - ya) * (centre[i].first - xa) / double(xb - xa);
    worst = std::max(worst, std::abs(centre[i].second - line));
  }
  EXPECT_LT(worst, 3.0);
}

TEST(TimelinePlot, EveryCurveIsVisibleAcrossThePlot) {
  test::TempDir dir;
  std::vector<TimelineSample> s;
  for (uint64_t k = 0; k <= 100; ++k) {
    TimelineSample t;
    t.seconds = double(k);
    t.keyframes = k;
    t.total = 1000 * k;
    t.resident = std::min<uint64_t>(t.total, 60000);
    t.rss_mb = 58;  // flat near the top of its axis, where a legend inside the plot would sit
    t.loads = k * k;
    s.push_back(t);
  }
  write_timeline_plot(dir / "m.png", s, 60000);
  const Image8 img = read_image8(dir / "m.png");
  const TimelinePlotLayout lay = timeline_plot_layout();
  auto column_has = [&](const TimelinePlotBox& b, int x, const Rgb& c) {
    for (int y = b.y0; y <= b.y1; ++y)
      if (is(img, x, y, c)) return true;
    return false;
  };
  int missing_rss = 0, missing_resident = 0, missing_loads = 0;
  // The x axis ends at the last sample (100 s), so every column of the plot area has each curve.
  for (int x = lay.gaussians.x0 + 2; x < lay.gaussians.x1 - 1; x += 3) {
    missing_rss += !column_has(lay.memory, x, kRss);
    missing_resident += !column_has(lay.gaussians, x, kResident);
    missing_loads += !column_has(lay.io, x, kLoads);
  }
  EXPECT_EQ(missing_rss, 0);
  EXPECT_EQ(missing_resident, 0);
  EXPECT_EQ(missing_loads, 0);
}

TEST(TimelinePlot, DrawsTheBudgetOnlyNearTheData) {
  test::TempDir dir;
  const auto s = long_run(false);
  write_timeline_plot(dir / "near.png", s, 1500000);
  write_timeline_plot(dir / "far.png", s, 500000000);
  const TimelinePlotBox b = timeline_plot_layout().gaussians;
  EXPECT_GT(count(read_image8(dir / "near.png"), b, kBudget), 50);
  EXPECT_EQ(count(read_image8(dir / "far.png"), b, kBudget), 0);
}

TEST(TimelinePlot, WritesEmptyAndSingleSampleTimelines) {
  test::TempDir dir;
  write_timeline_plot(dir / "empty.png", {}, 1000);
  TimelineSample one;
  one.seconds = 2;
  one.total = one.resident = 500;
  one.rss_mb = 40;
  write_timeline_plot(dir / "one.png", {one}, 1000);
  const Image8 img = read_image8(dir / "one.png");
  EXPECT_EQ(img.width(), timeline_plot_layout().width);
  EXPECT_GT(count(img, timeline_plot_layout().memory, kRss), 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "empty.png"));
}

}  // namespace
}  // namespace chungs
