#include "chungs/optim/prune.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace chungs {
namespace {

TEST(Prune, SelectsFaintAndOversizedGaussiansOnly) {
  GaussianParams p;
  p.resize(6);
  auto logit = [](double o) { return float(std::log(o / (1 - o))); };
  p.opacity = {logit(0.04), logit(0.06), logit(0.5), logit(0.9), logit(0.01), std::nanf("")};
  const std::vector<uint32_t> ids{0, 1, 2, 3, 5};
  const std::vector<float> radius{3.f, 4.f, 321.f, 319.f, 2.f};  // W = 640: limit 320 px
  PruneConfig paper;  // the paper's rule: no wait for young Gaussians, and the size test at 0.5 W
  paper.max_radius_fraction = 0.5f;
  const auto out = select_for_pruning(paper, view_of(p), ids, radius, 640);
  // Places in ids: slots 0 (faint), 2 (too large), 5 (diverged); slot 4 is not listed.
  EXPECT_EQ(out, (std::vector<uint32_t>{0, 2, 4}));
  const auto opacity_only = select_for_pruning(paper, view_of(p), ids, {}, 640);
  EXPECT_EQ(opacity_only, (std::vector<uint32_t>{0, 4}));
  EXPECT_THROW(select_for_pruning(paper, view_of(p), ids, std::vector<float>{1.f}, 640), Error);
  EXPECT_THROW(select_for_pruning(paper, view_of(p), std::vector<uint32_t>{6}, {}, 640), Error);
  PruneConfig waits;
  waits.min_visits = 5;
  EXPECT_THROW(select_for_pruning(waits, view_of(p), ids, radius, 640), Error);  // no visit counts given
}

TEST(Prune, TheDefaultSizeLimitIsTwiceTheImageWidth) {
  // Issue 20: a view passing next to an object sees its Gaussians larger than half the image; the
  // default keeps them up to twice its width. A faint or diverged Gaussian goes at any size.
  GaussianParams p;
  p.resize(4);
  auto logit = [](double o) { return float(std::log(o / (1 - o))); };
  p.opacity = {logit(0.5), logit(0.9), logit(0.04), std::nanf("")};
  const std::vector<uint32_t> ids{0, 1, 2, 3};
  const std::vector<float> radius{5000.f, 700.f, 1.f, 900.f};
  const PruneConfig defaults;  // a limit of 1280 px
  EXPECT_EQ(select_for_pruning(defaults, view_of(p), ids, radius, 640), (std::vector<uint32_t>{0, 2, 3}));
  PruneConfig off;
  off.max_radius_fraction = 0.0f;
  EXPECT_EQ(select_for_pruning(off, view_of(p), ids, radius, 640), (std::vector<uint32_t>{2, 3}));
  for (float bad : {-0.5f, INFINITY, NAN}) {
    PruneConfig c;
    c.max_radius_fraction = bad;
    EXPECT_THROW(c.validate(), Error) << bad;
  }
}

TEST(Prune, WaitsForYoungGaussiansButNotForDivergedOrOversizedOnes) {
  GaussianParams p;
  p.resize(5);
  auto logit = [](double o) { return float(std::log(o / (1 - o))); };
  p.opacity = {logit(0.04), logit(0.03), logit(0.02), std::nanf(""), logit(0.5)};
  const std::vector<uint32_t> visits{4, 5, 9, 0, 1};
  const std::vector<uint32_t> ids{0, 1, 2, 3, 4};
  const std::vector<float> radius{1.f, 1.f, 1.f, 1.f, 400.f};  // W = 640: 4 is too large
  PruneConfig c;
  c.max_radius_fraction = 0.5f;
  c.min_visits = 5;
  // 0 is faint but has been optimised in 4 steps only; 1 and 2 have had their 5.
  EXPECT_EQ(select_for_pruning(c, view_of(p), ids, radius, 640, visits), (std::vector<uint32_t>{1, 2, 3, 4}));
  c.min_visits = 0;  // the paper's rule: visits are not read
  EXPECT_EQ(select_for_pruning(c, view_of(p), ids, radius, 640), (std::vector<uint32_t>{0, 1, 2, 3, 4}));
  c.min_visits = 5;
  EXPECT_THROW(select_for_pruning(c, view_of(p), ids, radius, 640, std::vector<uint32_t>{9, 9}), Error);
  c.min_visits = -1;
  EXPECT_THROW(c.validate(), Error);
}

}  // namespace
}  // namespace chungs
