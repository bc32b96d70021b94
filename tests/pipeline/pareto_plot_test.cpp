// pareto.png: both pacing curves are drawn in their colours, the LPIPS panel holds curves only where
// points have LPIPS, and degenerate input (one point, equal values, no FPS) still gives the figure.
#include <gtest/gtest.h>

#include "chungs/image/image_io.hpp"
#include "chungs/pipeline/pareto_plot.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

int pixels_of(const Image8& img, const PlotRgb& c) {
  int n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) n += img(x, y, 0) == c[0] && img(x, y, 1) == c[1] && img(x, y, 2) == c[2];
  return n;
}

ParetoPoint point(bool anytime, const char* label, double fps, double psnr, std::optional<double> lpips) {
  ParetoPoint p;
  p.anytime = anytime;
  p.label = label;
  p.fps = fps;
  p.held_out = {psnr, 0.5 + psnr / 100, lpips};
  p.keyframes = {psnr + 1, 0.55 + psnr / 100, lpips ? std::optional<double>(*lpips - 0.02) : std::nullopt};
  return p;
}

Image8 draw(const std::vector<ParetoPoint>& points, const test::TempDir& dir) {
  write_pareto_plot(dir / "p.png", points, "no weights");
  return read_image8(dir / "p.png");
}

TEST(ParetoPlot, DrawsBothCurvesAndLpipsOnlyWhereGiven) {
  test::TempDir dir;
  std::vector<ParetoPoint> with, without;
  const double fps[] = {8, 3, 1.2}, psnr[] = {18, 20, 21};
  for (int i = 0; i < 3; ++i) {
    with.push_back(point(false, "10", fps[i], psnr[i], 0.4 - 0.05 * i));
    without.push_back(point(false, "10", fps[i], psnr[i], std::nullopt));
  }
  with.push_back(point(true, "1X", 10, 19, 0.35));
  with.push_back(point(true, "2X", 20, 17.5, 0.45));
  without.push_back(point(true, "1X", 10, 19, std::nullopt));
  without.push_back(point(true, "2X", 20, 17.5, std::nullopt));
  const Image8 a = draw(with, dir), b = draw(without, dir);
  EXPECT_EQ(a.width(), kParetoPlotWidth);
  EXPECT_EQ(a.height(), kParetoPlotHeight);
  const int fixed_with = pixels_of(a, kParetoFixed), fixed_without = pixels_of(b, kParetoFixed);
  const int any_with = pixels_of(a, kParetoAnytime), any_without = pixels_of(b, kParetoAnytime);
  EXPECT_GT(fixed_without, 500);
  EXPECT_GT(any_without, 300);
  // The third panel adds a third of each curve's pixels, roughly.
  EXPECT_GT(fixed_with, fixed_without * 5 / 4);
  EXPECT_GT(any_with, any_without * 5 / 4);
}

TEST(ParetoPlot, OnePointEqualValuesAndNoFpsStillDraw) {
  test::TempDir dir;
  const Image8 one = draw({point(false, "30", 2, 20, std::nullopt)}, dir);
  EXPECT_EQ(one.width(), kParetoPlotWidth);
  EXPECT_GT(pixels_of(one, kParetoFixed), 40);  // its marks and label
  // A point without a processing FPS has no place on the log axis: left out, the rest drawn.
  const Image8 none = draw({point(true, "1X", 0, 20, std::nullopt), point(true, "2X", 4, 20, std::nullopt)}, dir);
  EXPECT_GT(pixels_of(none, kParetoAnytime), 40);
  const Image8 alone = draw({point(true, "2X", 4, 20, std::nullopt)}, dir);
  for (int y = 0; y < alone.height(); ++y)
    for (int x = 0; x < alone.width(); ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(none(x, y, c), alone(x, y, c)) << x << "," << y;
  const Image8 empty = draw({}, dir);
  EXPECT_EQ(pixels_of(empty, kParetoFixed) + pixels_of(empty, kParetoAnytime), 0);
}

}  // namespace
}  // namespace chungs
