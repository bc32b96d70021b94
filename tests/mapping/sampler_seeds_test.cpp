// The tracker's map points as Gaussians of a keyframe (issue 25, sampler.map_point_seeds): each point in
// view becomes one Gaussian at its own position, coloured by its pixel and sized like a drawn pixel's
// at its depth, with no draw and no depth map needed; points behind or outside the view are not taken.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <set>

#include "chungs/mapping/sampler.hpp"

namespace chungs {
namespace {

TEST(SamplerSeeds, MapPointsBecomeGaussiansAtTheirPositions) {
  const Camera cam(80, 60, 60, 60, 39.5, 29.5);
  const SE3 pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())), Eigen::Vector3d(1, -0.5, 2));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(0, 1);
  ImageF image(80, 60, 3);
  for (auto& v : image.vec()) v = float(U(rng));
  ImageF probability(80, 60, 1, 0.0f);  // nothing drawn: only the seeds
  probability(10, 10) = 0.25f;          // one pixel where the render lacks detail
  const ImageF no_depth(80, 60, 1, 0.0f);
  std::vector<Eigen::Vector3d> seeds, inside;
  for (int k = 0; k < 60; ++k) {
    const Eigen::Vector2d px(U(rng) * 79, U(rng) * 59);
    const Eigen::Vector3d X = pose * cam.unproject(px, 2 + 6 * U(rng));
    seeds.push_back(X), inside.push_back(X);
  }
  // At the probed pixel, 4 m away.
  const Eigen::Vector3d at_probe = pose * cam.unproject(Eigen::Vector2d(10, 10), 4.0);
  seeds.push_back(at_probe), inside.push_back(at_probe);
  seeds.push_back(pose * Eigen::Vector3d(0, 0, -3));    // behind the camera
  seeds.push_back(pose * Eigen::Vector3d(50, 0, 3));    // outside the image
  SamplerConfig c;
  c.min_per_chunk_per_100k_px = 0;
  c.min_per_chunk_floor = 0;
  std::mt19937_64 draws(1);
  SampleStats st;
  const auto batches =
      sample_gaussians(c, image, no_depth, probability, cam, pose, 100.0, 7, 0, draws, &st, nullptr, 0, &seeds);
  EXPECT_EQ(st.seeds, inside.size());
  EXPECT_EQ(st.no_depth, st.candidates);  // the one pixel may be drawn, but has no depth: skipped
  size_t n = 0;
  std::multiset<std::array<float, 3>> got;
  for (const auto& b : batches)
    for (size_t i = 0; i < b.block.size(); ++i, ++n) {
      const auto& q = b.block.params;
      got.insert({q.mean[3 * i], q.mean[3 * i + 1], q.mean[3 * i + 2]});
      EXPECT_EQ(b.block.created_by_keyframe[i], 7u);
      const Eigen::Vector3d X(q.mean[3 * i], q.mean[3 * i + 1], q.mean[3 * i + 2]);
      const Eigen::Vector3d pc = pose.inverse() * X;
      const Eigen::Vector2d uv = cam.project(pc);
      const int x = int(std::lround(uv.x())), y = int(std::lround(uv.y()));
      // Colour of its pixel, size of a pixel drawn with the probability there (at least 1 %) at its depth.
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(q.sh[48 * i + ch], sh_dc_of_colour(image(x, y, ch)), 1e-6);
      const double p = std::max(double(probability(x, y)), kSeedMinProbability);
      const double px = std::clamp(1.0 / std::sqrt(p), c.min_scale_px, c.max_scale_fraction * 80);
      EXPECT_NEAR(q.log_scale[3 * i], std::log(px * pc.z() / cam.fx), 1e-5) << "seed at " << x << ", " << y;
    }
  ASSERT_EQ(n, inside.size());
  for (const auto& X : inside) {
    const std::array<float, 3> key{float(X.x()), float(X.y()), float(X.z())};
    EXPECT_EQ(got.count(key), 1u) << X.transpose();
  }
  // Without seeds the same call adds nothing.
  SampleStats none;
  EXPECT_TRUE(sample_gaussians(c, image, no_depth, probability, cam, pose, 100.0, 7, 0, draws, &none).empty());
}

}  // namespace
}  // namespace chungs
