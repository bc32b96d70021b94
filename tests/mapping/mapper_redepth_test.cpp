// Mapper::redepth: a later sweep's depth for a keyframe's guessed pixels replaces the guesses in its
// stored depth and moves the Gaussians placed at them along the keyframe's rays; nothing else moves.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/depth/guessed_depth.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/store/chunk_store.hpp"
#include "chungs/store/keyframe_store.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

struct Placed {
  Eigen::Vector3d mean;
  float log_scale0;
};

// Every Gaussian of the folder, by its colour and opacity (left alone by redepth).
std::map<std::array<float, 4>, Placed> gaussians(const std::filesystem::path& folder) {
  ChunkStore store(folder);
  std::map<std::array<float, 4>, Placed> out;
  for (ChunkId c : store.ids()) {
    const GaussianBlock b = store.load(c);
    for (size_t i = 0; i < b.size(); ++i) {
      const float* m = &b.params.mean[3 * i];
      const float* sh = &b.params.sh[size_t(kShFloats) * i];
      out[{sh[0], sh[1], sh[2], b.params.opacity[i]}] = {Eigen::Vector3d(m[0], m[1], m[2]), b.params.log_scale[3 * i]};
    }
  }
  return out;
}

TEST(MapperRedepth, LaterDepthReplacesTheGuessesAndMovesTheirGaussiansAlongTheRays) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.prune.every = 0;
  const test::WallSequence seq(1);
  const Frame f = seq.frame(0);
  const int w = f.camera.width, h = f.camera.height;
  // The left half guessed 20 % too far, the right half measured.
  ImageF depth = *f.depth;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w / 2; ++x) depth(x, y) = guessed_depth(1.2f * (*f.depth)(x, y));
  // The later sweep gives depth to the top half of the guesses (and says nothing of the measured side).
  ImageF fresh(w, h, 1, 0.0f);
  for (int y = 0; y < h / 2; ++y)
    for (int x = 0; x < w; ++x) fresh(x, y) = (*f.depth)(x, y);
  const SE3 T_cw = f.gt_pose->inverse();
  const auto pixel_of = [&](const Eigen::Vector3d& world, double& z) {
    const Eigen::Vector3d p = T_cw * world;
    z = p.z();
    const Eigen::Vector2d px = f.camera.project(p);
    return std::make_pair(int(std::lround(px.x())), int(std::lround(px.y())));
  };

  {
    Mapper m(dir / "map", c, false);
    m.add_keyframe(0, f.timestamp, f.left, depth, f.camera, *f.gt_pose);
    m.checkpoint({});
  }
  const std::map<std::array<float, 4>, Placed> before = gaussians(dir / "map");
  {
    Mapper m(dir / "map", c, true);  // resumed: the keyframe's depth and chunk index come back
    EXPECT_THROW(m.redepth(7, fresh), Error);  // no such keyframe
    EXPECT_THROW(m.redepth(0, ImageF(w - 1, h, 1, 0.0f)), Error);
    EXPECT_EQ(m.redepth(0, fresh), size_t(w / 2) * size_t(h / 2));
    EXPECT_EQ(m.redepth_totals().pixels, size_t(w / 2) * size_t(h / 2));
    m.checkpoint({});
  }
  const std::map<std::array<float, 4>, Placed> after = gaussians(dir / "map");
  ASSERT_EQ(before.size(), after.size());
  size_t moved = 0, kept = 0;
  for (const auto& [key, b] : before) {
    const Placed& a = after.at(key);
    double z = 0;
    const auto [x, y] = pixel_of(b.mean, z);
    if (x >= 0 && x < w / 2 && y >= 0 && y < h / 2) {
      // Now at the later depth, on the same ray (same pixel), its size scaled by the same factor.
      double z_after = 0;
      EXPECT_EQ(pixel_of(a.mean, z_after), std::make_pair(x, y));
      EXPECT_NEAR(z_after, (*f.depth)(x, y), 1e-4 * z_after);
      EXPECT_NEAR(a.log_scale0 - b.log_scale0, std::log(z_after / z), 1e-5);
      ++moved;
    } else {
      EXPECT_EQ(a.mean, b.mean) << "pixel " << x << "," << y;
      ++kept;
    }
  }
  EXPECT_GT(moved, 20u);
  EXPECT_GT(kept, 60u);
  // The stored depth holds the later depth where it replaced a guess, the rest as it was.
  KeyframeStore store(dir / "map" / "keyframes");
  const ImageF& stored = store.get(0)->depth;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float want = x < w / 2 && y < h / 2 ? (*f.depth)(x, y) : depth(x, y);
      ASSERT_EQ(stored(x, y), want) << x << "," << y;
    }
}

}  // namespace
}  // namespace chungs
