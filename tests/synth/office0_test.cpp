// The Replica office0 mesh rendered at the first recorded pose must match the real depth image:
// this pins down the axis, pose and pixel-centre conventions of the rasterizer.
#include <gtest/gtest.h>

#include "chungs/synth/mesh_render.hpp"
#include "test_support.hpp"

namespace chungs::synth {

TEST(Office0, RenderedDepthMatchesRealDepth) {
  CHUNGS_REQUIRE_DATA("replica_office0");
  const Office0Check c = check_office0(test::shared_data("replica_office0"));
  std::printf("office0: median |d| %.4f m, mean %.4f m, %zu of %zu pixels, render %.3f s\n", c.median_abs_diff,
              c.mean_abs_diff, c.valid_pixels, c.pixels, c.render_seconds);
  EXPECT_LT(c.median_abs_diff, 0.05);
  EXPECT_GT(c.valid_pixels, c.pixels / 2);
}

}  // namespace chungs::synth
