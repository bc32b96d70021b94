// BlockArrays: the 19 arrays of a GaussianBlock in their fixed order, laid out back to back in one
// buffer, and ranges of Gaussians copied between the two exactly as GaussianBlock::append_range does.
#include "chungs/gaussians/block_arrays.hpp"

#include <gtest/gtest.h>

#include <memory>

#include "chungs/common/error.hpp"
#include "store/random_block.hpp"

using namespace chungs;

TEST(BlockArrays, PointAtTheBlocksArraysInTheirFixedOrder) {
  GaussianBlock b = test::random_block(37, 3);
  const BlockArrays a = block_arrays(b);
  EXPECT_EQ(a.count, 37u);
  EXPECT_EQ(a.sh_degree, 3);
  EXPECT_EQ(a.data[0], b.params.mean.data());
  EXPECT_EQ(a.data[4], b.params.sh.data());
  EXPECT_EQ(a.data[5], b.adam_m.mean.data());
  EXPECT_EQ(a.data[13], b.adam_v.opacity.data());
  EXPECT_EQ(a.data[15], b.adam_steps.data());
  EXPECT_EQ(a.data[18], b.lr_position_factor.data());
  EXPECT_EQ(a.bytes(4), b.params.sh.size() * sizeof(float));
  const ConstBlockArrays c = a;  // a mutable view passes as a read-only one
  EXPECT_EQ(c.data[17], b.created_at_step.data());
}

TEST(BlockArrays, LaidOutArraysHoldARangeAsAppendRangeCopiesIt) {
  const GaussianBlock src = test::random_block(50, 8);
  const size_t first = 13, n = 21;
  GaussianBlock expected;
  expected.sh_degree = src.sh_degree;
  expected.append_range(src, first, n);
  // Into one buffer of laid-out arrays and back into a block: the same values.
  auto memory = std::make_unique<std::byte[]>(laid_out_bytes(n));
  const BlockArrays laid = laid_out_arrays(memory.get(), n, src.sh_degree);
  for (int a = 0; a + 1 < kBlockArrays; ++a) {  // one after another, none overlapping
    EXPECT_GE(static_cast<std::byte*>(laid.data[size_t(a) + 1]),
              static_cast<std::byte*>(laid.data[size_t(a)]) + laid.bytes(a));
    EXPECT_EQ(reinterpret_cast<uintptr_t>(laid.data[size_t(a)]) % 16, 0u);
  }
  EXPECT_LE(static_cast<std::byte*>(laid.data[18]) + laid.bytes(18), memory.get() + laid_out_bytes(n));
  copy_gaussians(block_arrays(src), first, n, laid);
  GaussianBlock back;
  back.resize(n);
  copy_gaussians(laid, 0, n, block_arrays(back));
  EXPECT_TRUE(test::same_bits(back, expected));
  // A range beyond either side is refused, not copied.
  EXPECT_THROW(copy_gaussians(block_arrays(src), 40, 11, laid), Error);
  EXPECT_THROW(copy_gaussians(block_arrays(src), 0, n + 1, laid), Error);
}
