#include "chungs/gaussians/gaussian_block.hpp"

#include <gtest/gtest.h>

#include "chungs/common/error.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

TEST(GaussianBlock, AssignRangeCopiesEveryArrayOfThoseGaussians) {
  const GaussianBlock all = test::random_block(50, 7);
  GaussianBlock part = test::random_block(3, 8);  // replaced whole, whatever it held
  part.assign_range(all, 12, 9);
  GaussianBlock want;
  want.sh_degree = all.sh_degree;
  for (size_t i = 12; i < 21; ++i) want.append(all, i);
  EXPECT_TRUE(test::same_bits(part, want));
  part.assign_range(all, 50, 0);
  EXPECT_EQ(part.size(), 0u);
  EXPECT_THROW(part.assign_range(all, 45, 6), Error);
}
