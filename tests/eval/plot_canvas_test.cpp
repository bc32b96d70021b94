// The plot canvas draws what it is asked to where it is asked (text in its own font, solid and dashed
// lines), nothing outside its clip box, and picks round axis steps that cover the values.
#include <gtest/gtest.h>

#include <algorithm>

#include "chungs/eval/plot_canvas.hpp"

namespace chungs {
namespace {

const PlotRgb kInk{200, 30, 40};

int count(const Image8& img, const PlotRgb& c, const PlotBox& b) {
  int n = 0;
  for (int y = std::max(0, b.y0); y <= std::min(img.height() - 1, b.y1); ++y)
    for (int x = std::max(0, b.x0); x <= std::min(img.width() - 1, b.x1); ++x)
      n += img(x, y, 0) == c[0] && img(x, y, 1) == c[1] && img(x, y, 2) == c[2];
  return n;
}

TEST(PlotCanvas, TextIsDrawnInItsCellAndDiffersByCharacter) {
  PlotCanvas a{Image8(100, 40, 3, 255)}, b{Image8(100, 40, 3, 255)};
  a.text(10, 10, "PSNR 12", kInk);
  b.text(10, 10, "PSNR 17", kInk);  // a 7 has fewer cells set than a 2
  const PlotBox cell{10, 10, 10 + PlotCanvas::width("PSNR 12") - 1, 10 + kPlotTextHeight - 1};
  const int inside = count(a.img, kInk, cell);
  EXPECT_GT(inside, 40);
  EXPECT_EQ(count(a.img, kInk, {0, 0, 99, 39}), inside);  // nothing outside the text's cells
  EXPECT_NE(count(a.img, kInk, cell), count(b.img, kInk, cell));
  // Lower case is drawn as the capitals.
  PlotCanvas c{Image8(100, 40, 3, 255)};
  c.text(10, 10, "psnr 12", kInk);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 100; ++x) ASSERT_EQ(c.img(x, y, 0), a.img(x, y, 0)) << x << "," << y;
}

TEST(PlotCanvas, LinesReachBothEndsAndDashesLeaveGaps) {
  PlotCanvas cv{Image8(120, 60, 3, 255)};
  cv.line(10, 20, 110, 20, kInk, 1);
  EXPECT_EQ(count(cv.img, kInk, {10, 20, 110, 20}), 101);
  cv.line(10, 40, 110, 40, kInk, 1, 5);
  const int dashed = count(cv.img, kInk, {10, 40, 110, 40});
  EXPECT_GT(dashed, 40);
  EXPECT_LT(dashed, 65);
  // A diagonal reaches its far end.
  cv.line(0, 0, 50, 55, kInk, 1);
  EXPECT_EQ(count(cv.img, kInk, {50, 55, 50, 55}), 1);
}

TEST(PlotCanvas, ClipKeepsLinesInsideTheBox) {
  PlotCanvas cv{Image8(100, 100, 3, 255)};
  cv.clip_to({20, 20, 60, 60});
  cv.line(0, 40, 99, 40, kInk, 3);
  cv.unclip();
  EXPECT_EQ(count(cv.img, kInk, {0, 0, 99, 99}), count(cv.img, kInk, {20, 20, 60, 60}));
  EXPECT_EQ(count(cv.img, kInk, {20, 39, 60, 41}), 41 * 3);
}

TEST(PlotCanvas, AxesCoverTheValuesInRoundSteps) {
  const PlotAxis a = plot_axis(105);
  EXPECT_EQ(a.start, 0);
  EXPECT_DOUBLE_EQ(a.step, 20);
  EXPECT_DOUBLE_EQ(a.end, 120);
  const PlotAxis q = plot_axis(17.3, 23.9);
  EXPECT_DOUBLE_EQ(q.step, 2);
  EXPECT_LE(q.start, 17.3);
  EXPECT_GE(q.end, 23.9);
  EXPECT_GT(q.start, 10);  // not from zero, where quality values would sit in a thin band
  EXPECT_LE(q.ticks, 8);
  const PlotAxis s = plot_axis(0.71, 0.74);
  EXPECT_LE(s.start, 0.71);
  EXPECT_GE(s.end, 0.74);
  EXPECT_LE(s.ticks, 8);
  EXPECT_EQ(plot_number(120), "120");
  EXPECT_EQ(plot_number(0.25), "0.25");
}

}  // namespace
}  // namespace chungs
