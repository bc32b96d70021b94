// Mapper::render of a view whose chunks hold more than the budget: drawn whole, in passes of chunks
// that fit, nearest first, not without its farthest chunks (whose pixels had shown the background).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/store/chunk_store.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

double mean_abs_diff(const ImageF& a, const ImageF& b) {
  double d = 0;
  for (size_t i = 0; i < a.vec().size(); ++i) d += std::fabs(double(a.vec()[i]) - double(b.vec()[i]));
  return d / double(a.vec().size());
}

double mean(const ImageF& a) {
  double s = 0;
  for (float v : a.vec()) s += v;
  return s / double(a.vec().size());
}

TEST(MapperRender, AViewBeyondTheBudgetIsDrawnWholeInPasses) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.store.chunk_size = 1.0;  // a dozen chunks in one view of the wall
  c.residency.async_io = false;
  const test::WallSequence seq(10, 64, 48, 0.1, 3.5);  // the wall halfway between chunk faces
  {
    Mapper m(dir / "map", c, false);
    for (size_t i = 0; i < seq.size(); ++i) {
      const Frame f = seq.frame(i);
      m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
      for (int k = 0; k < 4; ++k) m.step();
    }
    m.checkpoint({});
  }
  uint64_t largest_chunk = 0, total = 0;
  {
    const ChunkStore store(dir / "map");
    for (ChunkId id : store.ids())
      largest_chunk = std::max(largest_chunk, store.count(id)), total += store.count(id);
  }
  ASSERT_GT(total, 4 * largest_chunk) << "the map must hold several chunks' worth";
  const Frame f = seq.frame(5);
  RenderOutput<float> whole, parts;
  {
    Mapper m(dir / "map", c, true);
    whole = m.render(f.camera, *f.gt_pose);
    EXPECT_EQ(m.views_over_budget(), 0u);
    EXPECT_EQ(m.renders_in_passes(), 0u);
  }
  Config small = c;
  small.residency.budget_gaussians =
      size_t(0.6 * double(total));  // every chunk fits, the whole view does not
  {
    Mapper m(dir / "map", small, true);
    parts = m.render(f.camera, *f.gt_pose);
    EXPECT_EQ(m.views_over_budget(), 1u);
    EXPECT_EQ(m.renders_in_passes(), 1u);
  }
  const double covered = mean(whole.alpha);
  ASSERT_GT(covered, 0.5);
  size_t same = 0;  // pixels whose colour matches to 0.02
  for (int y = 0; y < whole.rgb.height(); ++y)
    for (int x = 0; x < whole.rgb.width(); ++x) {
      float d = 0;
      for (int k = 0; k < 3; ++k) d = std::max(d, std::fabs(parts.rgb(x, y, k) - whole.rgb(x, y, k)));
      same += d < 2e-2f;
    }
  const double same_share = double(same) / double(whole.rgb.width() * whole.rgb.height());
  std::printf("alpha %.4f whole, %.4f in passes; %.1f %% of the pixels the same colour\n", covered,
              mean(parts.alpha), 100 * same_share);
  // The far chunks are drawn: the wall covers the image as much as in the whole render (without
  // them, 60 % of its Gaussians). Pixels differ only in bands along the chunk faces between the
  // two passes, where splats overhang their chunk and the passes put the nearer chunk's first
  // instead of ordering coplanar splats by depth: wide here (1 m chunks are 14 px wide, splats
  // several px), narrow on a street (10 m chunks, ~100 px at 30 m).
  EXPECT_NEAR(mean(parts.alpha), covered, 2e-3);
  EXPECT_GT(same_share, 0.5);
  EXPECT_LT(mean_abs_diff(parts.inv_depth, whole.inv_depth), 0.01 * mean(whole.inv_depth));
}

}  // namespace
}  // namespace chungs
