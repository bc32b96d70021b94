// The plane sweep (depth/plane_sweep.hpp) on a ray-cast scene with exact depth: a wide sweep finds the
// textured surfaces, a perturbed prior is refined, flat areas and priors far off are dropped rather
// than guessed, dense and sampled modes agree, and bad input is refused by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/depth/plane_sweep.hpp"
#include "sweep_scene.hpp"

namespace chungs {
namespace {

using test::translated;

struct Views : test::SweepViews {
  PlaneSweepInput input() const { return SweepViews::input<PlaneSweepInput>(); }
  // Pixels of textured surfaces with a valid ground truth, away from the depth step and the borders.
  bool scored(int x, int y) const {
    if (x < 6 || y < 6 || x >= gt.width() - 6 || y >= gt.height() - 6 || gt(x, y) <= 0) return false;
    for (int dy = -4; dy <= 4; ++dy)
      for (int dx = -4; dx <= 4; ++dx)
        if (std::abs(gt(x + dx, y + dy) - gt(x, y)) > 0.5f) return false;
    return !flat(x, y);
  }
  bool flat(int x, int y) const { return x >= 104 && x <= 143 && y >= 16 && y <= 55; }  // the gray patch, +-4 px
  bool well_inside_flat(int x, int y) const { return x >= 112 && x <= 135 && y >= 24 && y <= 47; }
};

// The scene's baselines (0.2-0.6 m at 3.5-6 m, 120 px focal length) move the image 4-20 px per 10 %
// of depth: below the default parallax test's 10 % per pixel, so these tests relax it.
PlaneSweepConfig swept(double near = 0.5, double far = 80.0) {
  PlaneSweepConfig c;
  c.near = near, c.far = far;
  c.max_rel_per_px = 0.5;
  c.best_k = 2;  // of 3 neighbours: the one ahead does not see the borders
  return c;
}

struct Score {
  double abs_rel = 0;
  size_t valid = 0, scored = 0;
};

Score score(const Views& v, const ImageF& depth) {
  Score s;
  double sum = 0;
  for (int y = 0; y < depth.height(); ++y)
    for (int x = 0; x < depth.width(); ++x) {
      if (!v.scored(x, y)) continue;
      ++s.scored;
      if (depth(x, y) <= 0) continue;
      ++s.valid;
      sum += std::abs(depth(x, y) - v.gt(x, y)) / v.gt(x, y);
    }
  s.abs_rel = s.valid ? sum / double(s.valid) : 1e9;
  return s;
}

TEST(PlaneSweep, WideSweepWithoutPriorRecoversTexturedDepth) {
  const Views v;
  const PlaneSweepDepth d = plane_sweep_dense(v.input(), swept(1.0, 20.0));
  const Score s = score(v, d.depth);
  EXPECT_GT(double(s.valid), 0.8 * double(s.scored)) << s.valid << " of " << s.scored;
  EXPECT_LT(s.abs_rel, 0.02);
  std::printf("wide sweep: %zu of %zu scored pixels valid, AbsRel %.4f\n", s.valid, s.scored, s.abs_rel);
  size_t with_conf = 0;
  for (size_t i = 0; i < d.depth.pixels(); ++i) {
    ASSERT_EQ(d.depth.vec()[i] > 0, d.confidence.vec()[i] > 0) << "pixel " << i;
    with_conf += d.confidence.vec()[i] > 0;
  }
  EXPECT_EQ(with_conf, d.valid);
}

TEST(PlaneSweep, RefinesAPerturbedPriorFarBeyondItsError) {
  const Views v;
  // A prior off by up to +-15 % in inverse depth, varying smoothly as a fitted monocular prior would.
  ImageF prior(v.gt.width(), v.gt.height(), 1, 0.0f);
  for (int y = 0; y < prior.height(); ++y)
    for (int x = 0; x < prior.width(); ++x)
      if (v.gt(x, y) > 0) prior(x, y) = float((1.0 + 0.15 * std::sin(0.07 * x + 0.05 * y)) / v.gt(x, y));
  ImageF prior_depth(prior.width(), prior.height(), 1, 0.0f);
  for (size_t i = 0; i < prior.pixels(); ++i) prior_depth.vec()[i] = prior.vec()[i] > 0 ? 1.0f / prior.vec()[i] : 0.0f;
  PlaneSweepInput in = v.input();
  in.prior_inv_depth = &prior;
  const PlaneSweepDepth d = plane_sweep_dense(in, swept());
  const Score before = score(v, prior_depth), after = score(v, d.depth);
  EXPECT_GT(before.abs_rel, 0.05);
  EXPECT_LT(after.abs_rel, 0.2 * before.abs_rel) << "prior " << before.abs_rel << ", refined " << after.abs_rel;
  EXPECT_GT(double(after.valid), 0.8 * double(after.scored));
  std::printf("prior AbsRel %.4f, refined %.4f (%zu of %zu valid)\n", before.abs_rel, after.abs_rel, after.valid,
              after.scored);

  // The sampled mode computes the same function at the requested pixels.
  std::vector<SweepPixel> px;
  std::mt19937 rng(5);
  for (int i = 0; i < 300; ++i) px.push_back({int(rng() % 160), int(rng() % 120)});
  const std::vector<SweepSample> at = plane_sweep_at(in, px, swept());
  for (size_t i = 0; i < px.size(); ++i) {
    EXPECT_EQ(at[i].depth, d.depth(px[i].x, px[i].y)) << px[i].x << "," << px[i].y;
    EXPECT_EQ(at[i].confidence, d.confidence(px[i].x, px[i].y));
  }
}

TEST(PlaneSweep, TexturelessAreasAreDroppedByTheCostTestsAlone) {
  const Views v;
  std::vector<SweepPixel> flat, textured;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      if (v.well_inside_flat(x, y)) flat.push_back({x, y});
      if (v.scored(x, y) && (x + y) % 7 == 0) textured.push_back({x, y});
    }
  ASSERT_GT(flat.size(), 400u);
  PlaneSweepConfig c = swept(1.0, 20.0);
  c.min_texture = 0;  // the patch-variance test off: the cost and uniqueness tests must do it
  size_t kept = 0;
  for (const SweepSample& s : plane_sweep_at(v.input(), flat, c)) kept += s.depth > 0;
  EXPECT_LT(double(kept), 0.03 * double(flat.size())) << kept << " of " << flat.size() << " flat pixels kept";
  // ... while the same settings keep the textured pixels.
  size_t textured_kept = 0;
  for (const SweepSample& s : plane_sweep_at(v.input(), textured, c)) textured_kept += s.depth > 0;
  EXPECT_GT(double(textured_kept), 0.8 * double(textured.size()));
  // With the variance test on, no flat pixel at all.
  for (const SweepSample& s : plane_sweep_at(v.input(), flat, swept(1.0, 20.0))) EXPECT_EQ(s.depth, 0.0f);
}

// The reference's right side seen by one neighbour only: the two others are turned 15 degrees to the
// left, as the keyframes a camera turning right leaves behind. With min_views 1 that side gets depth
// from the one neighbour, as exact as the rest; requiring best_k (2) views left it without.
TEST(PlaneSweep, WhatOnlyOneNeighbourSeesGetsDepthFromIt) {
  Views v;
  const auto turned_left = [](double x, double y) {
    return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(-15.0 * M_PI / 180.0, Eigen::Vector3d::UnitY())),
               Eigen::Vector3d(x, y, 0));
  };
  v.poses = {translated(0.35, 0, 0), turned_left(-0.3, 0), turned_left(-0.2, 0.2)};
  ImageF unused;
  for (size_t i = 0; i < v.poses.size(); ++i) v.scene.render(v.poses[i], v.images[i], unused, 1.5, unsigned(2 + i));
  std::vector<SweepPixel> band;
  size_t seen_by_turned = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 124; x < 160; ++x) {
      if (!v.scored(x, y)) continue;
      band.push_back({x, y});
      const Eigen::Vector3d world = v.scene.camera.unproject(Eigen::Vector2d(x, y), v.gt(x, y));
      for (size_t i = 1; i < v.poses.size(); ++i) {
        const Eigen::Vector2d px = v.scene.camera.project(v.poses[i].inverse() * world);
        seen_by_turned += px.x() >= 0 && px.x() < 160 && px.y() >= 0 && px.y() < 120;
      }
    }
  ASSERT_GT(band.size(), 1000u);
  ASSERT_EQ(seen_by_turned, 0u) << "the turned neighbours must not see the band";
  PlaneSweepConfig c = swept(1.0, 20.0);
  c.min_views = 2;
  size_t kept = 0;
  for (const SweepSample& s : plane_sweep_at(v.input(), band, c)) kept += s.depth > 0;
  EXPECT_EQ(kept, 0u);
  c.min_views = 1;
  Score one;
  double sum = 0;
  const std::vector<SweepSample> got = plane_sweep_at(v.input(), band, c);
  for (size_t i = 0; i < band.size(); ++i) {
    if (!(got[i].depth > 0)) continue;
    ++one.valid;
    sum += std::abs(got[i].depth - v.gt(band[i].x, band[i].y)) / v.gt(band[i].x, band[i].y);
  }
  EXPECT_GT(double(one.valid), 0.7 * double(band.size())) << one.valid << " of " << band.size();
  EXPECT_LT(sum / double(std::max<size_t>(one.valid, 1)), 0.02);
  std::printf("seen by one neighbour: %zu of %zu pixels with depth, AbsRel %.4f (none with min_views 2)\n", one.valid,
              band.size(), sum / double(std::max<size_t>(one.valid, 1)));
  c.min_views = 3;  // above best_k
  EXPECT_THROW(plane_sweep_at(v.input(), band, c), Error);
}

TEST(PlaneSweep, AConfidentPriorFarOffIsDroppedNotFollowed) {
  const Views v;
  ImageF prior(160, 120, 1, 0.0f);  // twice the true inverse depth: the truth lies outside +-20 %
  for (size_t i = 0; i < prior.pixels(); ++i) prior.vec()[i] = v.gt.vec()[i] > 0 ? 2.0f / v.gt.vec()[i] : 0.0f;
  PlaneSweepInput in = v.input();
  in.prior_inv_depth = &prior;
  const PlaneSweepDepth d = plane_sweep_dense(in, swept());
  const Score s = score(v, d.depth);
  EXPECT_LT(double(s.valid), 0.05 * double(s.scored)) << s.valid << " of " << s.scored << " kept";
  // With no confidence in that prior the wide sweep takes over and finds the surfaces.
  ImageF none(160, 120, 1, 0.1f);
  in.prior_confidence = &none;
  std::vector<SweepPixel> px;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      if (v.scored(x, y) && (x + 2 * y) % 5 == 0) px.push_back({x, y});
  size_t kept = 0;
  double err = 0;
  const std::vector<SweepSample> wide = plane_sweep_at(in, px, swept(1.0, 20.0));
  for (size_t i = 0; i < px.size(); ++i)
    if (wide[i].depth > 0) ++kept, err += std::abs(wide[i].depth - v.gt(px[i].x, px[i].y)) / v.gt(px[i].x, px[i].y);
  EXPECT_GT(double(kept), 0.8 * double(px.size()));
  EXPECT_LT(err / double(std::max<size_t>(kept, 1)), 0.02);
}

TEST(PlaneSweep, ThePixelsNearTheEpipoleOfForwardMotionAreDropped) {
  // Neighbours straight behind (they see all the reference sees): near the image centre the image
  // barely moves, whatever the depth, so a match there says little about depth.
  Views v;
  v.poses = {translated(0, 0, -1.0), translated(0, 0, -1.6)};
  v.images.resize(2);
  ImageF unused;
  for (size_t i = 0; i < 2; ++i) v.scene.render(v.poses[i], v.images[i], unused, 1.5, unsigned(7 + i));
  std::vector<SweepPixel> centre, border;
  for (int y = 8; y < 112; y += 2)
    for (int x = 8; x < 152; x += 2) {
      if (!v.scored(x, y)) continue;
      const double r = std::hypot(x - 79.5, y - 59.5);
      if (r < 15) centre.push_back({x, y});
      if (r > 55) border.push_back({x, y});
    }
  auto run = [&](const std::vector<SweepPixel>& px, double max_rel, size_t& kept) {
    PlaneSweepConfig c = swept(1.0, 20.0);
    c.max_rel_per_px = max_rel;
    const std::vector<SweepSample> got = plane_sweep_at(v.input(), px, c);
    double err = 0;
    kept = 0;
    for (size_t i = 0; i < px.size(); ++i)
      if (got[i].depth > 0) ++kept, err += std::abs(got[i].depth - v.gt(px[i].x, px[i].y)) / v.gt(px[i].x, px[i].y);
    return kept ? err / double(kept) : 0.0;
  };
  size_t centre_off = 0, centre_on = 0, border_on = 0;
  const double err_off = run(centre, 1e3, centre_off);
  run(centre, 0.1, centre_on);
  const double err_border = run(border, 0.1, border_on);
  std::printf("centre: %zu of %zu kept without the test (AbsRel %.3f), %zu with; border: %zu of %zu (AbsRel %.3f)\n",
              centre_off, centre.size(), err_off, centre_on, border_on, border.size(), err_border);
  EXPECT_EQ(centre_on, 0u);
  EXPECT_GT(centre_off, 0u);  // matches were found there: it is the parallax test that drops them
  EXPECT_GT(double(border_on), 0.5 * double(border.size()));
  EXPECT_LT(err_border, 0.03);
  EXPECT_GT(err_off, 2 * err_border);  // what the test drops was the worse part
}

TEST(PlaneSweep, RefusesBadInputByName) {
  const Views v;
  auto throws = [](auto&& f, const char* needle) {
    try {
      f();
      ADD_FAILURE() << "no error, expected one naming " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  PlaneSweepInput in = v.input();
  in.neighbours.clear();
  throws([&] { plane_sweep_dense(in); }, "0 neighbour views");
  in = v.input();
  const Image8 small(80, 60, 1, 7);
  in.neighbours[1].image = &small;
  throws([&] { plane_sweep_dense(in); }, "neighbour 1 is 80x60");
  in = v.input();
  ImageF prior(159, 120, 1, 0.2f);
  in.prior_inv_depth = &prior;
  throws([&] { plane_sweep_dense(in); }, "159x120");
  in = v.input();
  throws([&] { plane_sweep_at(in, {{3, 4}, {160, 5}}); }, "pixel 1 (160, 5)");
  throws([&] { plane_sweep_dense(in, {.near = 5, .far = 2}); }, "near 5");
  throws([&] { plane_sweep_dense(in, {.min_hypotheses = 16, .max_hypotheses = 300}); }, "hypotheses 16 to 300");
  in.camera.dist[0] = 0.1;
  throws([&] { plane_sweep_dense(in); }, "undistorted");
}

TEST(SweepNeighbours, PrefersUsefulBaselinesThatSeeTheSameScene) {
  const Camera cam(160, 120, 120, 120, 79.5, 59.5);
  const double a = M_PI / 180;
  auto yawed = [](double yaw, const Eigen::Vector3d& t) {
    return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY())), t);
  };
  std::vector<SE3> poses = {
      SE3(),                                   // 0: the reference
      translated(0.01, 0, 0),                  // 1: too short a baseline (0.06 deg at 10 m)
      translated(0.9, 0, 0),                   // 2: about 5 deg: ideal
      translated(0.3, 0, 0),                   // 3: about 1.7 deg
      translated(4.0, 0, 0),                   // 4: about 22 deg, and sees less
      yawed(90 * a, Eigen::Vector3d(0.5, 0, 0)),  // 5: looks sideways
      translated(0, 0, 30.0),                  // 6: far ahead, past the scene: sees none of it
      translated(-0.8, 0.2, 0.3),              // 7: about 5 deg the other way
  };
  const std::vector<size_t> got = select_sweep_neighbours(cam, poses, 0, {.count = 4});
  ASSERT_EQ(got.size(), 4u);
  EXPECT_TRUE((got[0] == 2 && got[1] == 7) || (got[0] == 7 && got[1] == 2)) << got[0] << " " << got[1];
  EXPECT_EQ(got[2], 3u);
  EXPECT_EQ(got[3], 4u);
  // Straight ahead by 1 m: no parallax at the centre, a useful mean angle over the view.
  poses.push_back(translated(0, 0, 1.0));  // 8
  const std::vector<size_t> ahead = select_sweep_neighbours(cam, poses, 0, {.count = 10, .min_angle_deg = 1.0});
  EXPECT_NE(std::find(ahead.begin(), ahead.end(), size_t(8)), ahead.end());
  const std::vector<size_t> all = select_sweep_neighbours(cam, poses, 0, {.count = 10});
  for (size_t j : all) EXPECT_TRUE(j != 0 && j != 1 && j != 5 && j != 6) << j;
  EXPECT_THROW(select_sweep_neighbours(cam, poses, poses.size()), Error);
}

}  // namespace
}  // namespace chungs
