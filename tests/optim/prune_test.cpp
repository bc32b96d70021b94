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
  const auto out = select_for_pruning({}, view_of(p), ids, radius, 640);
  EXPECT_EQ(out, (std::vector<uint32_t>{0, 2, 5}));  // faint, too large, diverged; 4 is not listed
  const auto opacity_only = select_for_pruning({}, view_of(p), ids, {}, 640);
  EXPECT_EQ(opacity_only, (std::vector<uint32_t>{0, 5}));
  EXPECT_THROW(select_for_pruning({}, view_of(p), ids, std::vector<float>{1.f}, 640), Error);
  EXPECT_THROW(select_for_pruning({}, view_of(p), std::vector<uint32_t>{6}, {}, 640), Error);
}

}  // namespace
}  // namespace chungs
