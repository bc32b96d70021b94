// A budget below what one chunk's new Gaussians need: the Gaussians it cannot hold are counted and
// reported with the budget that would hold them, and a run whose every Gaussian was refused fails
// instead of writing an empty map.
#include <gtest/gtest.h>

#include <string>

#include "chungs/common/error.hpp"
#include "pipeline/street_run.hpp"

namespace chungs {
namespace {

nlohmann::json street_under(uint64_t budget) {
  return test::map_test_street(20, 64, 32, 1, [&](Config& c) { c.residency.budget_gaussians = budget; });
}

TEST(BudgetRefusal, ARunWhoseEveryNewGaussianIsRefusedFailsNamingTheBudgetThatHoldsThem) {
  try {
    street_under(1);
    FAIL() << "a budget of 1 Gaussian mapped an empty street without an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("--budget 1:"), std::string::npos) << m;
    EXPECT_NE(m.find("the map is empty"), std::string::npos) << m;
    EXPECT_NE(m.find("a budget of at least "), std::string::npos) << m;
  }
}

TEST(BudgetRefusal, NewGaussiansAChunkCannotHoldAreCountedWithTheBudgetThatHoldsThem) {
  const nlohmann::json tight = street_under(60);
  const nlohmann::json& g = tight["gaussians"];
  EXPECT_GT(g["total"].get<uint64_t>(), 0u);
  ASSERT_GT(g["refused_over_budget"].get<uint64_t>(), 0u);
  const uint64_t least = g["least_budget_for_refused"].get<uint64_t>();
  EXPECT_GT(least, 60u);
  // Four times that budget holds every chunk this street's keyframes make.
  const nlohmann::json enough = street_under(4 * least);
  EXPECT_EQ(enough["gaussians"]["refused_over_budget"].get<uint64_t>(), 0u);
  EXPECT_FALSE(enough["gaussians"].contains("least_budget_for_refused"));
}

}  // namespace
}  // namespace chungs
