// The refinement of measured depth (depth/depth_refine.hpp) on the wall-and-box scene with exact depth:
// depths perturbed within the band move back toward the truth, never leave the band, stay where the
// surface has no texture, match the plane sweep asked pixel by pixel, and bad input is refused by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/depth/depth_refine.hpp"
#include "sweep_scene.hpp"

namespace chungs {
namespace {

struct Views : test::SweepViews {
  PlaneSweepInput input() const { return SweepViews::input<PlaneSweepInput>(); }
  // Away from the borders, the box's edge and the flat patch.
  bool textured(int x, int y) const {
    if (x < 6 || y < 6 || x >= gt.width() - 6 || y >= gt.height() - 6 || gt(x, y) <= 0) return false;
    for (int dy = -4; dy <= 4; ++dy)
      for (int dx = -4; dx <= 4; ++dx)
        if (std::abs(gt(x + dx, y + dy) - gt(x, y)) > 0.5f) return false;
    return !(x >= 104 && x <= 143 && y >= 16 && y <= 55);
  }
  bool well_inside_flat(int x, int y) const { return x >= 112 && x <= 135 && y >= 24 && y <= 47; }
};

// The scene's baselines (0.2-0.6 m at 3.5-6 m, 120 px focal length) fail the default parallax test;
// of its 3 neighbours the one ahead does not see the borders (plane_sweep_test.cpp says the same).
PlaneSweepConfig sweep() {
  PlaneSweepConfig c;
  c.max_rel_per_px = 0.5;
  c.best_k = 2;
  return c;
}

// Every 3rd pixel of the textured surfaces, its true inverse depth shifted by a random share of
// `range` within +-`share`.
std::vector<PixelDepth> perturbed(const Views& v, double range, double share, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-share, share);
  std::vector<PixelDepth> px;
  for (int y = 0; y < v.gt.height(); y += 3)
    for (int x = 0; x < v.gt.width(); x += 3)
      if (v.textured(x, y)) px.push_back({x, y, float(1.0 / (1.0 / v.gt(x, y) + U(rng) * range))});
  return px;
}

double median_inv_error(const Views& v, const std::vector<PixelDepth>& px) {
  std::vector<double> e;
  for (const PixelDepth& p : px) e.push_back(std::abs(1.0 / p.depth - 1.0 / v.gt(p.x, p.y)));
  std::nth_element(e.begin(), e.begin() + long(e.size() / 2), e.end());
  return e[e.size() / 2];
}

// The stereo band (+-0.01 1/m) spans under a pixel in the standard views' neighbours (0.2-0.6 m
// baselines at 120 px focal length), where no match tells depths apart: the sweep's uniqueness test
// refuses most such pixels, and the measurement stays. Neighbours 1.5-2 m away make it span 4-5 px.
Views wide_baselines() {
  Views v;
  v.poses = {test::translated(1.5, 0, 0), test::translated(-1.2, 1.2, 0.1), test::translated(0.3, -1.6, 0.4)};
  ImageF unused;
  for (size_t i = 0; i < v.poses.size(); ++i) v.scene.render(v.poses[i], v.images[i], unused, 1.5, unsigned(20 + i));
  return v;
}

TEST(DepthRefine, PerturbedDepthMovesBackTowardTheTruthWithinItsBand) {
  for (double range : {0.05, 0.01}) {  // the paper's RGB-D and stereo bands, 1/m
    const Views v = range < 0.03 ? wide_baselines() : Views();
    const std::vector<PixelDepth> before = perturbed(v, range, 0.7, 3);
    std::vector<PixelDepth> after = before;
    const DepthRefineStats s = refine_depths(v.input(), after, range, sweep());
    ASSERT_EQ(s.asked, before.size());
    EXPECT_GT(double(s.refined), 0.7 * double(s.asked)) << "range " << range;
    const double e0 = median_inv_error(v, before), e1 = median_inv_error(v, after);
    std::printf("band +-%.2f: %zu of %zu refined, median inverse-depth error %.5f -> %.5f 1/m\n", range, s.refined,
                s.asked, e0, e1);
    EXPECT_LT(e1, 0.25 * e0) << "range " << range;
    size_t moved = 0;
    for (size_t i = 0; i < before.size(); ++i) {
      const double d = std::abs(1.0 / after[i].depth - 1.0 / before[i].depth);
      EXPECT_LE(d, range * (1 + 1e-4)) << "pixel " << before[i].x << "," << before[i].y;
      moved += after[i].depth != before[i].depth;
    }
    EXPECT_EQ(moved, s.refined);
  }
}

TEST(DepthRefine, TexturelessPixelsAndPixelsWithoutDepthKeepWhatTheyHad) {
  const Views v;
  std::vector<PixelDepth> px;
  for (int y = 24; y <= 47; y += 4)
    for (int x = 112; x <= 135; x += 4) px.push_back({x, y, 6.3f});  // the flat patch, 0.3 m off
  px.push_back({20, 60, 0.0f});
  px.push_back({24, 60, std::numeric_limits<float>::quiet_NaN()});
  std::vector<PixelDepth> out = px;
  const DepthRefineStats s = refine_depths(v.input(), out, 0.05, sweep());
  EXPECT_EQ(s.asked, px.size() - 2);
  // ... and so does a band the neighbours see as under a pixel (the stereo band in these views).
  std::vector<PixelDepth> narrow = perturbed(v, 0.01, 0.7, 4), kept = narrow;
  EXPECT_LT(double(refine_depths(v.input(), kept, 0.01, sweep()).refined), 0.25 * double(narrow.size()));
  EXPECT_EQ(s.refined, 0u);
  for (size_t i = 0; i + 2 < px.size(); ++i) EXPECT_EQ(out[i].depth, px[i].depth);
  EXPECT_EQ(out[px.size() - 2].depth, 0.0f);
  EXPECT_TRUE(std::isnan(out.back().depth));
}

// The band is the sweep's own narrow mode: the same numbers as plane_sweep_at with the measurement as
// a dense prior and prior_abs_range, at random pixels and measurements.
TEST(DepthRefine, IsThePlaneSweepAroundTheMeasurementPixelByPixel) {
  const Views v;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-0.04, 0.04);
  std::vector<PixelDepth> px;
  ImageF prior(v.gt.width(), v.gt.height(), 1, 0.0f);
  for (int i = 0; i < 400; ++i) {
    const int x = int(rng() % 160), y = int(rng() % 120);
    if (prior(x, y) != 0 || v.gt(x, y) <= 0) continue;
    const float z = float(1.0 / (1.0 / v.gt(x, y) + U(rng)));
    px.push_back({x, y, z});
    prior(x, y) = 1.0f / z;
  }
  std::vector<PixelDepth> out = px;
  refine_depths(v.input(), out, 0.05, sweep());
  PlaneSweepInput in = v.input();
  in.prior_inv_depth = &prior;
  PlaneSweepConfig c = sweep();
  c.prior_abs_range = 0.05;
  std::vector<SweepPixel> at;
  for (const PixelDepth& p : px) at.push_back({p.x, p.y});
  const std::vector<SweepSample> ref = plane_sweep_at(in, at, c);
  size_t valid = 0;
  for (size_t i = 0; i < px.size(); ++i) {
    EXPECT_EQ(out[i].depth, ref[i].depth > 0 ? ref[i].depth : px[i].depth) << i;
    valid += ref[i].depth > 0;
  }
  EXPECT_GT(valid, px.size() / 2);
}

TEST(DepthRefine, TheBandStopsAtTheSweepsNearAndFar) {
  const Views v;
  // The wall at 6 m with a far end at 5 m: the band (1/6 -+ 0.05) is cut to [1/5, 1/4.3], which no
  // longer holds the wall, so the best match lies at the cut end and the depth stays.
  PlaneSweepConfig c = sweep();
  c.far = 5.0;
  std::vector<PixelDepth> px;
  for (int y = 8; y < 112; y += 6)
    for (int x = 8; x < 50; x += 6)
      if (v.textured(x, y) && v.gt(x, y) > 5.5f) px.push_back({x, y, v.gt(x, y)});
  ASSERT_GT(px.size(), 20u);
  std::vector<PixelDepth> out = px;
  EXPECT_LE(refine_depths(v.input(), out, 0.05, c).refined, px.size() / 10);
  for (size_t i = 0; i < px.size(); ++i)
    EXPECT_TRUE(out[i].depth == px[i].depth || (out[i].depth <= 5.0f + 1e-3f && out[i].depth >= 4.6f))
        << i << ": " << out[i].depth;
  // Entirely beyond far (the band's near end under 1/far): no depth from the sweep, the measurement stays.
  c.far = 2.0, c.near = 0.5;
  out = px;
  EXPECT_EQ(refine_depths(v.input(), out, 0.05, c).refined, 0u);
  for (size_t i = 0; i < px.size(); ++i) EXPECT_EQ(out[i].depth, px[i].depth);
}

TEST(DepthRefine, RefusesBadInputByName) {
  const Views v;
  std::vector<PixelDepth> px{{10, 10, 5.0f}};
  for (double bad : {0.0, -0.01, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()})
    EXPECT_THROW(refine_depths(v.input(), px, bad, sweep()), Error) << bad;
  std::vector<PixelDepth> outside{{160, 10, 5.0f}};
  EXPECT_THROW(refine_depths(v.input(), outside, 0.05, sweep()), Error);
  std::vector<PixelDepth> twice{{10, 10, 5.0f}, {10, 10, 4.0f}};
  EXPECT_THROW(refine_depths(v.input(), twice, 0.05, sweep()), Error);
  PlaneSweepConfig c = sweep();
  c.prior_abs_range = -1;
  EXPECT_THROW(c.validate(), Error);
  c.prior_abs_range = std::numeric_limits<double>::infinity();
  EXPECT_THROW(c.validate(), Error);
  PlaneSweepInput none = v.input();
  none.neighbours.clear();
  EXPECT_THROW(refine_depths(none, px, 0.05, sweep()), Error);
}

}  // namespace
}  // namespace chungs
