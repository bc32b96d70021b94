// A view drawn in passes, nearest splats first, composited front to back: the same picture as one
// render of all splats when every splat of a pass lies behind every splat of the passes before it.
#include "chungs/render/render_passes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/render/cpu/rasterizer.hpp"
#include "random_scene.hpp"

namespace chungs {
namespace {

float max_abs_diff(const Image<float>& a, const Image<float>& b) {
  float d = 0;
  for (size_t i = 0; i < a.vec().size(); ++i) d = std::max(d, std::fabs(a.vec()[i] - b.vec()[i]));
  return d;
}

TEST(RenderPasses, PassesByDepthCompositeToTheRenderOfAllSplats) {
  for (unsigned seed : {4u, 5u, 6u}) {
    const test::RandomScene s = test::make_random_scene(seed, 90, 53, 41, 2.5);
    const test::SceneArrays<float> g = s.g.cast<float>();
    // Three passes by the splats' depth in the camera, each listed in random order.
    const SE3 world_to_camera = s.pose.inverse();
    std::vector<std::vector<uint32_t>> passes(3);
    std::vector<uint32_t> all;
    for (uint32_t i = 0; i < g.size(); ++i) {
      const Eigen::Vector3d pw(s.g.mean[3 * i], s.g.mean[3 * i + 1], s.g.mean[3 * i + 2]);
      const double z = (world_to_camera * pw).z();  // 1.5 .. 4 m
      passes[z < 2.3 ? 0 : z < 3.1 ? 1 : 2].push_back(i);
      all.push_back(i);
    }
    for (const auto& p : passes) ASSERT_GT(p.size(), 10u) << "seed " << seed;
    RasterConfig cfg;
    cfg.background = {0.3, 0.1, 0.6};
    CpuRasterizer<float> r(cfg);
    const RenderCamera<float> cam = make_render_camera<float>(s.camera, s.pose);
    const RenderOutput<float> whole = r.forward(g.view(), all, cam);
    int rendered = 0;
    const RenderOutput<float> parts = render_front_to_back(
        passes,
        [&](const std::vector<uint32_t>& ids) {
          ++rendered;
          return r.forward(g.view(), ids, cam);
        },
        cfg.background);
    EXPECT_EQ(rendered, 3);
    // Float rounding apart (~1e-7 here); where the light left fell below min_transmittance (1e-4)
    // one render would stop and the passes draw on, scaled by what is left.
    EXPECT_LT(max_abs_diff(parts.rgb, whole.rgb), 1e-5f) << "seed " << seed;
    EXPECT_LT(max_abs_diff(parts.alpha, whole.alpha), 1e-5f);
    EXPECT_LT(max_abs_diff(parts.depth, whole.depth), 5e-5f);  // metres, 1.5-4 m away
    EXPECT_LT(max_abs_diff(parts.inv_depth, whole.inv_depth), 1e-5f);
    EXPECT_EQ(parts.visible.size(), g.size());
    EXPECT_EQ(parts.radius.size(), g.size());
    // Not the picture of the passes in the wrong order: the test can tell.
    std::vector<std::vector<uint32_t>> reversed(passes.rbegin(), passes.rend());
    const RenderOutput<float> wrong = render_front_to_back(
        reversed, [&](const std::vector<uint32_t>& ids) { return r.forward(g.view(), ids, cam); },
        cfg.background);
    EXPECT_GT(max_abs_diff(wrong.rgb, whole.rgb), 0.05f);
  }
}

TEST(RenderPasses, PassesOfOtherSizesAreRefused) {
  RenderOutput<float> a, b;
  a.rgb = ImageF(8, 6, 3), a.depth = a.inv_depth = a.alpha = ImageF(8, 6, 1);
  b.rgb = ImageF(8, 5, 3), b.depth = b.inv_depth = b.alpha = ImageF(8, 5, 1);
  EXPECT_THROW(composite_behind(a, b, {0, 0, 0}), Error);
}

}  // namespace
}  // namespace chungs
