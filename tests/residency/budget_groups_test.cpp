// Cutting a view's chunks, nearest first, into groups that each fit the budget.
#include "chungs/residency/budget_groups.hpp"

#include <gtest/gtest.h>

#include "chungs/common/error.hpp"

namespace chungs {
namespace {

TEST(BudgetGroups, ConsecutiveGroupsWithinTheBudgetInTheGivenOrder) {
  // Counts 40, 50, 0, 30, 90, 120, 10, 60 with a budget of 100.
  const std::vector<ChunkCount> near = {{11, 40}, {12, 50},  {13, 0},  {14, 30},
                                        {15, 90}, {16, 120}, {17, 10}, {18, 60}};
  const BudgetGroups g = split_by_budget(near, 100);
  // 14 does not fit beside 11 and 12 and starts a group even though 17 would have fitted there: a
  // later group never holds a chunk nearer than one of an earlier group.
  const std::vector<std::vector<ChunkId>> want = {{11, 12}, {14}, {15, 17}, {18}};
  EXPECT_EQ(g.groups, want);
  EXPECT_EQ(g.too_large, std::vector<ChunkId>{16});
}

TEST(BudgetGroups, AViewThatFitsIsOneGroup) {
  const BudgetGroups g = split_by_budget({{1, 30}, {2, 30}, {3, 40}}, 100);
  ASSERT_EQ(g.groups.size(), 1u);
  EXPECT_EQ(g.groups[0], (std::vector<ChunkId>{1, 2, 3}));
  EXPECT_TRUE(g.too_large.empty());
  EXPECT_TRUE(split_by_budget({}, 100).groups.empty());
  EXPECT_THROW(split_by_budget({{1, 1}}, 0), Error);
}

}  // namespace
}  // namespace chungs
