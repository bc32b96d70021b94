// Depth of a keyframe from one camera (depth/multiview_depth.hpp) on the plane sweep's ray-cast scene:
// the grid sweep spread edge-aware covers the textured surfaces with a small error, a map-point prior
// narrows it and is said to, the flat patch on the wall takes the wall's depth, map points project as depth samples, and
// bad settings are refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/depth/hole_fill.hpp"
#include "chungs/depth/multiview_depth.hpp"
#include "sweep_scene.hpp"

namespace chungs {
namespace {

using test::translated;

struct Views : test::SweepViews {
  Views() = default;
  explicit Views(test::SweepViews v) : test::SweepViews(std::move(v)) {}
  MultiviewDepthInput input() const { return SweepViews::input<MultiviewDepthInput>(); }
  bool flat(int x, int y) const { return x >= 108 && x <= 139 && y >= 20 && y <= 51; }
};

// As the plane sweep's tests: these baselines move the image less than the default parallax test
// asks at this scene's depths, and the view ahead does not see the borders.
MultiviewDepthConfig config() {
  MultiviewDepthConfig c;
  c.sweep.max_rel_per_px = 0.5;
  c.sweep.best_k = 2;
  return c;
}

struct Score {
  double abs_rel = 0, coverage = 0, flat_abs_rel = 0;
  size_t valid = 0, flat_valid = 0;
};

// Over the textured pixels with ground truth, 6 px from the borders (the patch does not reach them).
Score score(const Views& v, const ImageF& placed) {
  // A fill's guess (negated) counts as depth here: it is where the Gaussians go.
  ImageF depth = placed;
  for (float& z : depth.vec()) z = std::abs(z);
  Score s;
  double sum = 0;
  size_t textured = 0;
  for (int y = 6; y < depth.height() - 6; ++y)
    for (int x = 6; x < depth.width() - 6; ++x) {
      if (v.flat(x, y)) {
        if (depth(x, y) > 0 && v.gt(x, y) > 0)
          ++s.flat_valid, s.flat_abs_rel += std::abs(depth(x, y) - v.gt(x, y)) / v.gt(x, y);
        continue;
      }
      if (v.gt(x, y) <= 0) continue;
      ++textured;
      if (depth(x, y) <= 0) continue;
      ++s.valid;
      sum += std::abs(depth(x, y) - v.gt(x, y)) / v.gt(x, y);
    }
  s.abs_rel = s.valid ? sum / double(s.valid) : 1e9;
  s.coverage = double(s.valid) / double(std::max<size_t>(textured, 1));
  s.flat_abs_rel /= double(std::max<size_t>(s.flat_valid, 1));
  return s;
}

TEST(MultiviewDepth, AGridSweepSpreadEdgeAwareCoversTheTexturedSurfaces) {
  const Views v;
  const MultiviewDepth d = multiview_depth(v.input(), config(), nullptr);
  const Score s = score(v, d.depth);
  std::printf("stride 4: %zu swept, %zu matched, coverage %.3f, AbsRel %.4f, flat patch pixels with depth %zu\n",
              d.swept, d.matched, s.coverage, s.abs_rel, s.flat_valid);
  EXPECT_EQ(d.swept, size_t(40 * 30));  // 160x120 at stride 4
  EXPECT_FALSE(d.prior);
  EXPECT_GT(s.coverage, 0.8);
  EXPECT_LT(s.abs_rel, 0.05);
  const auto with_depth = [](const MultiviewDepth& m) {
    return size_t(std::count_if(m.depth.vec().begin(), m.depth.vec().end(), [](float z) { return z != 0; }));
  };
  const auto measured = [](const MultiviewDepth& m) {
    return size_t(std::count_if(m.depth.vec().begin(), m.depth.vec().end(), [](float z) { return z > 0; }));
  };
  EXPECT_EQ(d.valid + d.filled, with_depth(d));
  EXPECT_EQ(with_depth(d), d.depth.pixels()) << "the fill gives every pixel depth";
  EXPECT_GT(d.filled, 0u);
  // The fill's depth is negated: a place for Gaussians, not a target for the depth loss ...
  EXPECT_EQ(measured(d), d.valid);
  for (size_t i = 0; i < d.depth.pixels(); ++i)
    ASSERT_EQ(d.depth.vec()[i] != 0, d.confidence.vec()[i] > 0) << "pixel " << i;
  // ... unless it is to supervise as well: the same depths, positive.
  MultiviewDepthConfig supervised = config();
  supervised.supervise_fill = true;
  const MultiviewDepth ds = multiview_depth(v.input(), supervised, nullptr);
  EXPECT_EQ(measured(ds), d.valid + d.filled);
  for (size_t i = 0; i < d.depth.pixels(); ++i) ASSERT_EQ(ds.depth.vec()[i], std::abs(d.depth.vec()[i])) << "pixel " << i;
  // Without the fill, only the spread's confident pixels have depth, and the filled ones were not.
  MultiviewDepthConfig no_fill = config();
  no_fill.fill_holes = false;
  const MultiviewDepth spread = multiview_depth(v.input(), no_fill, nullptr);
  EXPECT_EQ(spread.filled, 0u);
  EXPECT_EQ(spread.valid, with_depth(spread));
  EXPECT_EQ(spread.valid, d.valid);
  for (size_t i = 0; i < d.depth.pixels(); ++i) {
    if (spread.depth.vec()[i] > 0) {
      ASSERT_EQ(spread.depth.vec()[i], d.depth.vec()[i]) << "pixel " << i;
    }
  }
  // The untextured patch lies on the wall: where the spread reaches it, it carries the wall's depth,
  // which is the patch's (the sweep alone keeps none of it).
  EXPECT_LT(s.flat_abs_rel, 0.05);
}

// An untextured patch of the wall beside the box's edge, the wall bright and the box dark: the sweep
// matches neither the patch nor (at the box's edge) its border, and the fill must say where it lies.
// The membrane blends the box's depth into it from its left side; the edge-aware spread leans towards
// the wall, whose brightness it shares: here 0.170 against 0.190 (indoors, Replica office0 and the
// synthetic room: AbsRel of the filled pixels 0.21 / 0.11 with the spread, 0.25 / 0.14 with the
// membrane alone).
TEST(MultiviewDepth, FilledPixelsFollowTheSurfaceOfTheirBrightness) {
  test::SweepScene scene;
  scene.quads.push_back({{-8, -6, 6}, {16, 0, 0}, {0, 12, 0}, 0.15, 3, false, 0.15, 105});
  scene.quads.push_back({{-1.2, -0.8, 3.5}, {1.6, 0, 0}, {0, 1.4, 0}, 0.09, 5, false, 0.15, 0});
  // On the wall, from the box's right edge in the reference view (image columns 93-119, rows 32-80).
  scene.quads.push_back({{0.675, -1.375, 5.99}, {1.325, 0, 0}, {0, 2.4, 0}, 0.15, 9, true, 1, 0, 125});
  const Views v{test::SweepViews(scene)};
  const MultiviewDepth d = multiview_depth(v.input(), config(), nullptr);
  // The membrane alone, from the same kept depths, for comparison.
  ImageF kept(d.depth.width(), d.depth.height(), 1, 0.0f);
  for (size_t i = 0; i < kept.vec().size(); ++i)
    if (d.depth.vec()[i] > 0) kept.vec()[i] = 1.0f / d.depth.vec()[i];
  const ImageF membrane = fill_holes_membrane(kept);
  double spread_err = 0, membrane_err = 0;
  size_t n = 0;
  for (int y = 34; y <= 78; ++y)
    for (int x = 94; x <= 118; ++x) {
      const float z = d.depth(x, y), t = v.gt(x, y);
      ASSERT_NEAR(t, 5.99, 0.01) << x << "," << y;
      if (!(z < 0)) continue;
      spread_err += std::abs(-z - t) / t;
      membrane_err += std::abs(1.0f / membrane(x, y) - t) / t;
      ++n;
    }
  ASSERT_GT(n, 200u);
  spread_err /= double(n), membrane_err /= double(n);
  std::printf("patch pixels filled %zu of %d, AbsRel %.4f (the membrane alone %.4f)\n", n, 25 * 45, spread_err,
              membrane_err);
  EXPECT_LT(spread_err, 0.95 * membrane_err);
}

TEST(MultiviewDepth, MapPointsNarrowTheSweepAroundTheirPrior) {
  const Views v;
  MultiviewDepthInput in = v.input();
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> X(8, 151), Y(8, 111);
  // 300 points with 3 % depth noise, off the flat patch (features need texture).
  std::normal_distribution<float> noise(0.0f, 0.03f);
  while (in.points.size() < 300) {
    const int x = X(rng), y = Y(rng);
    if (v.flat(x, y) || v.gt(x, y) <= 0) continue;
    in.points.push_back({float(x), float(y), v.gt(x, y) * (1.0f + noise(rng)), 1.0f});
  }
  const MapPointPrior prior(20, DensifyConfig{});
  const MultiviewDepth d = multiview_depth(in, config(), &prior);
  const Score s = score(v, d.depth);
  std::printf("with a prior of 300 points: coverage %.3f, AbsRel %.4f\n", s.coverage, s.abs_rel);
  EXPECT_TRUE(d.prior);
  EXPECT_GT(s.coverage, 0.8);
  EXPECT_LT(s.abs_rel, 0.05);
  // Too few points give no prior: the sweep goes wide.
  in.points.resize(10);
  EXPECT_FALSE(multiview_depth(in, config(), &prior).prior);
}

// The second pass (anchor_confidence): the grid pixels the first pass swept wide are swept again,
// narrow, around the spread of its confident matches, and the depth is at least as good as one pass's.
// Where map points already narrowed the sweep, there is nothing to sweep again.
TEST(MultiviewDepth, TheSecondPassSweepsAroundTheFirstPassesConfidentMatches) {
  const Views v;
  MultiviewDepthConfig one = config();
  one.anchor_confidence = 0;
  const MultiviewDepth a = multiview_depth(v.input(), one, nullptr);
  const MultiviewDepth b = multiview_depth(v.input(), config(), nullptr);
  const Score sa = score(v, a.depth), sb = score(v, b.depth);
  std::printf("one pass: %zu matched, coverage %.3f, AbsRel %.4f; two: %zu swept again, %zu matched, coverage %.3f, "
              "AbsRel %.4f\n",
              a.matched, sa.coverage, sa.abs_rel, b.reswept, b.matched, sb.coverage, sb.abs_rel);
  EXPECT_EQ(a.reswept, 0u);
  EXPECT_GT(b.reswept, b.swept / 2) << "most of the grid has confident matches around it";
  EXPECT_LE(b.reswept, b.swept);
  EXPECT_GE(b.matched + b.swept / 100, a.matched);
  EXPECT_LT(sb.abs_rel, sa.abs_rel * 0.95);  // 0.0307 -> 0.0242 measured
  EXPECT_GE(sb.coverage, sa.coverage - 0.01);
  // Its prior spread on the image at half size (what keyframes wider than anchor_width get) still says
  // where to look.
  MultiviewDepthConfig coarse = config();
  coarse.anchor_width = 80;
  const MultiviewDepth h = multiview_depth(v.input(), coarse, nullptr);
  const Score sh = score(v, h.depth);
  std::printf("two, prior at half size: %zu swept again, coverage %.3f, AbsRel %.4f\n", h.reswept, sh.coverage,
              sh.abs_rel);
  EXPECT_GT(h.reswept, h.swept / 2);
  EXPECT_LT(sh.abs_rel, sa.abs_rel * 0.95);
  EXPECT_GE(sh.coverage, sa.coverage - 0.01);
  // Map points everywhere: the first pass is already narrow wherever the prior is confident.
  MultiviewDepthInput in = v.input();
  for (int y = 4; y < 120; y += 4)
    for (int x = 4; x < 160; x += 4)
      if (v.gt(x, y) > 0) in.points.push_back({float(x), float(y), v.gt(x, y), 1.0f});
  const MapPointPrior prior(20, DensifyConfig{});
  const MultiviewDepth c = multiview_depth(in, config(), &prior);
  EXPECT_TRUE(c.prior);
  EXPECT_LT(c.reswept, b.reswept / 4) << "only where the map points' prior is not confident";
}

TEST(MultiviewDepth, EveryPixelSweptIsSpreadTheSameWay) {
  const Views v;
  MultiviewDepthConfig c = config();
  c.stride = 1;
  const MultiviewDepth d = multiview_depth(v.input(), c, nullptr);
  const Score s = score(v, d.depth);
  std::printf("stride 1: coverage %.3f, AbsRel %.4f\n", s.coverage, s.abs_rel);
  EXPECT_EQ(d.swept, size_t(160 * 120));
  EXPECT_GT(s.coverage, 0.8);
  EXPECT_LT(s.abs_rel, 0.05);
}

TEST(MultiviewDepth, ProjectsMapPointsInFrontAndInsideOnly) {
  const Camera cam(100, 80, 50, 50, 49.5, 39.5);
  const SE3 T_wc = translated(1, 2, 3);
  const std::vector<Eigen::Vector3d> world = {
      {1, 2, 7},        // straight ahead, 4 m: the principal point
      {1, 2, 1},        // behind
      {1 + 40, 2, 5},   // far outside to the right
      {1.5, 2.25, 5},   // inside: (49.5 + 12.5, 39.5 + 6.25) at 2 m
      {std::nan(""), 0, 5}};
  const std::vector<DepthSample> s = project_points(world, cam, T_wc);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_NEAR(s[0].x, 49.5, 1e-4);
  EXPECT_NEAR(s[0].y, 39.5, 1e-4);
  EXPECT_NEAR(s[0].depth, 4.0, 1e-5);
  EXPECT_NEAR(s[1].x, 62.0, 1e-4);
  EXPECT_NEAR(s[1].y, 45.75, 1e-4);
  EXPECT_NEAR(s[1].depth, 2.0, 1e-5);
}

TEST(MultiviewDepth, BadSettingsAndInputsAreRefusedByName) {
  const Views v;
  auto refused = [&](auto change, const char* word) {
    MultiviewDepthConfig c = config();
    MultiviewDepthInput in = v.input();
    change(c, in);
    try {
      multiview_depth(in, c, nullptr);
      ADD_FAILURE() << "accepted: " << word;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  };
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.stride = 0; }, "stride");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.neighbours = 9; }, "neighbours");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.refine_neighbours = 0; }, "refine_neighbours");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.refresh_after = c.keep_keyframes; }, "refresh_after");
  static const ImageF small(10, 10, 1, -1.0f);
  refused([](MultiviewDepthConfig&, MultiviewDepthInput& in) { in.again = &small; }, "earlier depth");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.min_confidence = 1.5; }, "min_confidence");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.anchor_confidence = -0.1; }, "anchor_confidence");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.anchor_width = 8; }, "anchor_width");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.anchor_confidence = std::nan(""); }, "anchor_confidence");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.choice.scene_depth = 0; }, "scene_depth");
  refused([](MultiviewDepthConfig& c, MultiviewDepthInput&) { c.choice.scene_depth = std::nan(""); }, "scene_depth");
  refused([](MultiviewDepthConfig&, MultiviewDepthInput& in) { in.units_per_metre = 0; }, "units_per_metre");
  refused([](MultiviewDepthConfig&, MultiviewDepthInput& in) { in.neighbours.clear(); }, "neighbour");
  refused([](MultiviewDepthConfig&, MultiviewDepthInput& in) { in.reference.image = nullptr; }, "reference");
}

// Made again (MultiviewDepthInput::again): only the earlier depth's guesses are swept, with its
// measured pixels as anchors; the result holds the guesses that got depth, at the true depth, and
// nothing where the earlier depth measured or had nothing.
TEST(MultiviewDepth, MadeAgainOnlyTheGuessesAreSweptAndOnlyTheyGetDepth) {
  const Views v;
  const int w = v.gt.width(), h = v.gt.height();
  ImageF earlier(w, h, 1, 0.0f);
  size_t guessed_grid = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float z = v.gt(x, y);
      if (!(z > 0) || y >= 100) continue;  // the bottom rows: nothing before
      const bool guess = x < 64;
      earlier(x, y) = guess ? -1.5f * z : z;  // the guesses half as far again as the truth
      guessed_grid += guess && x % 4 == 2 && y % 4 == 2;
    }
  MultiviewDepthInput in = v.input();
  in.again = &earlier;
  const MultiviewDepth d = multiview_depth(in, config(), nullptr);
  EXPECT_EQ(d.swept, guessed_grid);
  EXPECT_EQ(d.filled, 0u);
  size_t valid = 0, textured_guesses = 0;
  double sum = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float z = d.depth(x, y);
      ASSERT_GE(z, 0.0f) << "no guesses in the result";
      if (!(earlier(x, y) < 0)) {
        ASSERT_EQ(z, 0.0f) << x << "," << y << ": only guesses get depth";
        continue;
      }
      if (x >= 6 && y >= 6 && !v.flat(x, y)) ++textured_guesses;
      if (z > 0) ++valid, sum += std::abs(z - v.gt(x, y)) / v.gt(x, y);
    }
  EXPECT_EQ(valid, d.valid);
  EXPECT_GT(double(valid), 0.8 * double(textured_guesses)) << valid << " of " << textured_guesses;
  EXPECT_LT(sum / double(std::max<size_t>(valid, 1)), 0.05);
  std::printf("made again: %zu guesses swept, %zu pixels given depth, AbsRel %.4f\n", d.swept, valid,
              sum / double(std::max<size_t>(valid, 1)));
  // Nothing guessed: nothing swept.
  ImageF measured = earlier;
  for (float& z : measured.vec()) z = std::abs(z);
  in.again = &measured;
  const MultiviewDepth none = multiview_depth(in, config(), nullptr);
  EXPECT_EQ(none.swept, 0u);
  EXPECT_EQ(none.valid, 0u);
}

}  // namespace
}  // namespace chungs
