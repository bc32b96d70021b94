// sampler.view_budget_share: under a budget below what one keyframe's view holds, the mapper lowers the
// sampling density so that the largest such view would hold that share of the budget, and the map it
// makes is sparser than without the setting; with a budget every view fits, the density is unchanged.
#include <gtest/gtest.h>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

struct Mapped {
  uint64_t total, views_over_budget, largest_view;
  double density_scale;
};

Mapped map_wall(const Config& c) {
  test::TempDir dir;
  const test::WallSequence seq(10, 64, 48, 0.1, 3.5);
  Mapper m(dir / "map", c, false);
  for (size_t i = 0; i < seq.size(); ++i) {
    const Frame f = seq.frame(i);
    m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    for (int k = 0; k < 4; ++k) m.step();
  }
  return {m.total_gaussians(), m.views_over_budget(), m.largest_view(), m.density_scale()};
}

Config wall_config() {
  log::set_level(log::Level::Warn);
  Config c = test::tiny_mapping_config();
  c.store.chunk_size = 1.0;  // a dozen chunks in one view of the wall
  c.residency.async_io = false;
  return c;
}

TEST(MapperViewBudget, AViewOverTheBudgetLowersTheDensityToFitTheShare) {
  Config c = wall_config();
  const Mapped whole = map_wall(c);
  ASSERT_EQ(whole.views_over_budget, 0u);
  EXPECT_EQ(whole.density_scale, 1.0);
  c.residency.budget_gaussians = size_t(0.5 * double(whole.total));
  const Mapped plain = map_wall(c);
  ASSERT_GT(plain.views_over_budget, 0u) << "the budget must be below what a view holds";
  EXPECT_EQ(plain.density_scale, 1.0);  // off by default
  c.sampler.view_budget_share = 0.6;
  const Mapped fitted = map_wall(c);
  ASSERT_GT(fitted.views_over_budget, 0u);
  // share * budget / the largest keyframe view over the budget: below the share, and no lower than for
  // the largest view of all (steps' views included).
  EXPECT_LT(fitted.density_scale, 0.6);
  EXPECT_GE(fitted.density_scale, 0.6 * double(c.residency.budget_gaussians) / double(fitted.largest_view) - 1e-12);
  std::printf("total %llu without a budget, %llu under %zu, %llu with the density at %.3fx\n",
              (unsigned long long)whole.total, (unsigned long long)plain.total, c.residency.budget_gaussians,
              (unsigned long long)fitted.total, fitted.density_scale);
  EXPECT_LT(double(fitted.total), 0.95 * double(plain.total));
}

TEST(MapperViewBudget, ABudgetThatHoldsEveryViewKeepsTheDensity) {
  Config c = wall_config();
  c.sampler.view_budget_share = 0.6;
  const Mapped m = map_wall(c);
  EXPECT_EQ(m.views_over_budget, 0u);
  EXPECT_EQ(m.density_scale, 1.0);
}

}  // namespace
}  // namespace chungs
