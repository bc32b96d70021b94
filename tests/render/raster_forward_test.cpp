// Forward pass of the tiled CPU rasterizer against an untiled brute-force reference and closed-form
// cases: pixel-centre convention, depth order, early termination, culling, index lists.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "chungs/common/error.hpp"
#include "chungs/render/cpu/rasterizer.hpp"
#include "random_scene.hpp"
#include "reference_render.hpp"

namespace chungs {
namespace {

double max_abs_diff(const Image<double>& a, const Image<double>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a.data()[i] - b.data()[i]));
  return m;
}

// One Gaussian per call: isotropic scale, given pixel position, depth, opacity logit and DC colour.
void put(test::SceneArrays<double>& g, const Camera& cam, double u, double v, double z, double sigma,
         double logit, const std::array<double, 3>& rgb) {
  const size_t i = g.size();
  g.mean.insert(g.mean.end(), {(u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z});
  g.log_scale.insert(g.log_scale.end(), 3, std::log(sigma));
  g.rotation.insert(g.rotation.end(), {1, 0, 0, 0});
  g.opacity.push_back(logit);
  g.sh.resize(size_t(kShFloats) * (i + 1), 0.0);
  for (int c = 0; c < 3; ++c) g.sh[size_t(kShFloats) * i + c] = (rgb[c] - 0.5) / sh::kC0;
}

TEST(RasterForward, MatchesBruteForceReferenceAcrossTilesAndBorders) {
  for (unsigned seed : {1u, 2u, 3u}) {
    // 83 x 45: neither side a multiple of 16; Gaussians up to ~20 px wide span several tiles.
    test::RandomScene s = test::make_random_scene(seed, 60, 83, 45, 3.0);
    for (size_t i = 0; i < 10; ++i)
      for (int k = 0; k < 3; ++k) s.g.log_scale[3 * i + k] += 1.5;
    const auto ids = test::iota_ids(s.g.size());
    for (RasterConfig cfg : {RasterConfig{}, smooth_raster_config()}) {
      cfg.background = {0.2, 0.4, 0.1};
      CpuRasterizer<double> r(cfg);
      const auto& out = r.forward(s.g.view(), ids, make_render_camera<double>(s.camera, s.pose));
      const auto ref = test::reference_render(s.g, ids, s.camera, s.pose, cfg);
      EXPECT_LT(max_abs_diff(out.rgb, ref.rgb), 1e-12) << "seed " << seed;
      EXPECT_LT(max_abs_diff(out.depth, ref.depth), 1e-12);
      EXPECT_LT(max_abs_diff(out.inv_depth, ref.inv_depth), 1e-12);
      EXPECT_LT(max_abs_diff(out.alpha, ref.alpha), 1e-12);
      int diff_ids = 0;
      for (size_t i = 0; i < ref.top_id.size(); ++i) diff_ids += out.top_id.data()[i] != ref.top_id.data()[i];
      EXPECT_EQ(diff_ids, 0);
      EXPECT_GT(r.tile_entries(), s.g.size());  // some Gaussians sit in several tiles
    }
  }
}

TEST(RasterConfig, TheLowPassKeepsItsAngleOnSmallImages) {
  // Issue 20: 0.3 px^2 at 620x188 and above; at 310x94 (a quarter of the pixels) a quarter of it, the
  // same solid angle; at most 16x smaller; as given with a reference of 0.
  const RasterConfig c;
  EXPECT_DOUBLE_EQ(c.low_pass_for(620, 188), 0.3);
  EXPECT_DOUBLE_EQ(c.low_pass_for(1241, 376), 0.3);
  EXPECT_NEAR(c.low_pass_for(310, 94), 0.075, 1e-15);
  EXPECT_NEAR(c.low_pass_for(40, 30), 0.3 / 16, 1e-15);
  RasterConfig off;
  off.small_image_reference_px = 0;
  EXPECT_DOUBLE_EQ(off.low_pass_for(40, 30), 0.3);
  EXPECT_THROW(c.low_pass_for(0, 30), Error);
  for (double bad : {-1.0, double(NAN), double(INFINITY)}) {
    RasterConfig b;
    b.small_image_reference_px = bad;
    EXPECT_THROW(b.validate(), Error) << bad;
  }
}

TEST(RasterConfig, SegmentEntriesAreOffOrAWorkableRun) {
  for (int good : {0, 32, 2048, 1 << 24}) {
    RasterConfig c;
    c.segment_entries = good;
    EXPECT_NO_THROW(c.validate()) << good;
  }
  for (int bad : {-1, 1, 31, (1 << 24) + 1}) {
    RasterConfig c;
    c.segment_entries = bad;
    EXPECT_THROW(c.validate(), Error) << bad;
  }
}

// With and without the anti-aliased low-pass: with it, the peak opacity is o sqrt(det(cov - lp I) /
// det(cov)), so a splat the low-pass widens keeps the weight it had (RasterConfig::antialias). The sub-pixel
// case (0.004 m at 2.5 m: ~0.1 px) is where that factor is far from 1.
TEST(RasterForward, SingleGaussianFollowsClosedFormAtIntegerPixelCentres) {
  const Camera cam(40, 30, 50, 60, 13.25, 17.5);
  const double z = 2.5, o = 0.7;
  for (auto [antialias, sigma] : {std::pair{true, 0.1}, std::pair{false, 0.1}, std::pair{true, 0.004}}) {
    test::SceneArrays<double> g;
    put(g, cam, 20.0, 12.0, z, sigma, std::log(o / (1 - o)), {0.9, 0.3, 0.6});
    // On the optical axis of the pixel grid the projected covariance is diagonal only at the principal
    // point; evaluate the EWA formula exactly for this position instead.
    const double x = (20.0 - cam.cx) / cam.fx * z, y = (12.0 - cam.cy) / cam.fy * z;
    Eigen::Matrix<double, 2, 3> J;
    J << cam.fx / z, 0, -cam.fx * x / (z * z), 0, cam.fy / z, -cam.fy * y / (z * z);
    // 40x30 is below the reference size: the low-pass is 0.3 px^2 / 16 (RasterConfig::low_pass_for).
    const Eigen::Matrix2d bare = sigma * sigma * J * J.transpose();
    const Eigen::Matrix2d cov = bare + 0.3 / 16 * Eigen::Matrix2d::Identity();
    const Eigen::Matrix2d conic = cov.inverse();
    RasterConfig cfg;
    cfg.antialias = antialias;
    CpuRasterizer<double> r(cfg);
    const auto& out = r.forward(g.view(), test::iota_ids(1), make_render_camera<double>(cam, SE3()));
    const double peak = antialias ? o * std::sqrt(bare.determinant() / cov.determinant()) : o;
    if (sigma < 0.01) EXPECT_LT(peak, 0.5 * o);  // the case must exercise the factor
    for (int v : {12, 14, 9})
      for (int u : {20, 21, 17}) {
        const Eigen::Vector2d d(u - 20.0, v - 12.0);
        const double q = d.dot(conic * d), a0 = peak * std::exp(-0.5 * q);
        const double a = q <= 9 && a0 >= 1.0 / 255 ? a0 : 0.0;  // the 3-sigma and alpha cut-offs
        EXPECT_NEAR(out.rgb(u, v, 0), a * 0.9, 1e-12) << u << "," << v << " antialias " << antialias;
        EXPECT_NEAR(out.rgb(u, v, 1), a * 0.3, 1e-12);
        EXPECT_NEAR(out.alpha(u, v), a, 1e-12);
        EXPECT_NEAR(out.depth(u, v), a * z, 1e-12);
        EXPECT_NEAR(out.inv_depth(u, v), a / z, 1e-12);
        EXPECT_EQ(out.top_id(u, v), a > 0 ? 0u : kNoGaussian);
      }
    EXPECT_EQ(out.top_id(0, 0), kNoGaussian);  // far outside 3 sigma
    EXPECT_EQ(out.alpha(0, 0), 0.0);
    EXPECT_EQ(out.visible[0], 1);
    EXPECT_NEAR(out.radius[0], 3 * std::sqrt(cov.eigenvalues().real().maxCoeff()), 1e-9);
  }
}

TEST(RasterForward, FrontGaussianOccludesWhateverTheListOrder) {
  const Camera cam(32, 32, 40, 40, 16, 16);
  test::SceneArrays<double> g;
  put(g, cam, 16, 16, 5.0, 0.3, 0.5, {0.1, 0.2, 0.9});  // far, blue
  put(g, cam, 16, 16, 2.0, 0.1, 0.8, {0.9, 0.1, 0.1});  // near, red
  RasterConfig cfg;
  cfg.antialias = false;  // the peaks as given: this is about the order, not the low-pass
  CpuRasterizer<double> r(cfg);
  const double on = 1 / (1 + std::exp(-0.8)), of = 1 / (1 + std::exp(-0.5));
  for (const auto& ids : {std::vector<uint32_t>{0, 1}, std::vector<uint32_t>{1, 0}}) {
    const auto& out = r.forward(g.view(), ids, make_render_camera<double>(cam, SE3()));
    // At the common centre both have G = 1 (up to the low-pass, which scales neither peak).
    EXPECT_NEAR(out.rgb(16, 16, 0), on * 0.9 + (1 - on) * of * 0.1, 1e-12);
    EXPECT_NEAR(out.rgb(16, 16, 2), on * 0.1 + (1 - on) * of * 0.9, 1e-12);
    EXPECT_NEAR(out.depth(16, 16), on * 2.0 + (1 - on) * of * 5.0, 1e-12);
    EXPECT_EQ(out.top_id(16, 16), 1u);
  }
}

TEST(RasterForward, StopsBeforeTheSplatThatTakesTransmittanceBelowCutoff) {
  const Camera cam(16, 16, 20, 20, 8, 8);
  test::SceneArrays<double> g;
  const double logit = std::log(0.95 / 0.05);
  for (int i = 0; i < 6; ++i) put(g, cam, 8, 8, 1.0 + i, 0.5 * (1.0 + i), logit, {0.1 * i, 0.5, 0.2});
  RasterConfig cfg;
  cfg.antialias = false;  // the peaks as given: this is about the cut-off, not the low-pass
  CpuRasterizer<double> r(cfg);
  const auto& out = r.forward(g.view(), test::iota_ids(6), make_render_camera<double>(cam, SE3()));
  // T after 3 splats is 0.05^3 = 1.25e-4; the 4th would leave 6.25e-6 < 1e-4, so it and the rest are
  // skipped (G = 1 at the centre, sigma chosen to keep it so).
  double T = 1, red = 0;
  for (int i = 0; i < 3; ++i) red += 0.95 * T * 0.1 * i, T *= 0.05;
  EXPECT_NEAR(out.alpha(8, 8), 1 - T, 1e-12);
  EXPECT_NEAR(out.rgb(8, 8, 0), red, 1e-12);
}

TEST(RasterForward, CullsBehindNearPlaneAndRendersOnlyListedSlots) {
  const Camera cam(24, 20, 30, 30, 11, 9);
  test::SceneArrays<double> g;
  put(g, cam, 12, 10, 0.005, 0.001, 2.0, {1, 1, 1});  // in front of the camera but nearer than 0.01
  put(g, cam, 5, 5, 2.0, 0.1, 1.0, {1, 0, 0});
  put(g, cam, 18, 14, 2.0, 0.1, 1.0, {0, 1, 0});
  CpuRasterizer<double> r;
  const auto& out = r.forward(g.view(), std::vector<uint32_t>{0, 2}, make_render_camera<double>(cam, SE3()));
  EXPECT_EQ(out.visible, (std::vector<uint8_t>{0, 1}));
  EXPECT_EQ(out.radius[0], 0.0);
  EXPECT_EQ(out.alpha(5, 5), 0.0);  // slot 1 is not in the list
  EXPECT_GT(out.rgb(18, 14, 1), 0.5);
  EXPECT_EQ(out.top_id(18, 14), 2u);
}

TEST(RasterForward, EmptyListOrDivergedGaussiansRenderTheBackground) {
  const Camera cam(20, 18, 25, 25, 9.5, 8.5);
  test::SceneArrays<double> g;
  put(g, cam, 10, 9, 2.0, 0.2, 1.0, {0.5, 0.5, 0.5});
  put(g, cam, 10, 9, 2.0, 0.2, 1.0, {0.5, 0.5, 0.5});
  g.opacity[0] = std::numeric_limits<double>::quiet_NaN();
  g.sh[48 * 1 + 4] = std::numeric_limits<double>::infinity();
  RasterConfig cfg;
  cfg.background = {0.1, 0.2, 0.3};
  CpuRasterizer<double> r(cfg);
  const auto rc = make_render_camera<double>(cam, SE3());
  for (const auto& ids : {std::vector<uint32_t>{}, std::vector<uint32_t>{0, 1}}) {
    const auto& out = r.forward(g.view(), ids, rc);
    for (int y = 0; y < 18; ++y)
      for (int x = 0; x < 20; ++x) {
        EXPECT_EQ(out.rgb(x, y, 2), 0.3);
        EXPECT_EQ(out.alpha(x, y), 0.0);
      }
    GaussianGrads<double> grads;
    r.backward(RenderGrads<double>{Image<double>(20, 18, 3, 1.0), {}, {}, {}}, grads);
    for (double v : grads.mean) EXPECT_EQ(v, 0.0);
  }
}

TEST(RasterForward, RejectsBadInput) {
  const Camera cam(8, 8, 10, 10, 4, 4);
  test::SceneArrays<double> g;
  put(g, cam, 4, 4, 2.0, 0.1, 1.0, {1, 0, 0});
  CpuRasterizer<double> r;
  const auto rc = make_render_camera<double>(cam, SE3());
  EXPECT_THROW(r.forward(g.view(), std::vector<uint32_t>{1}, rc), Error);  // slot out of range
  GaussianGrads<double> grads;
  EXPECT_THROW(r.backward({}, grads), Error);  // nothing rendered yet
  r.forward(g.view(), std::vector<uint32_t>{0}, rc);
  RenderGrads<double> bad{Image<double>(7, 8, 3), {}, {}, {}};
  EXPECT_THROW(r.backward(bad, grads), Error);
  Camera distorted = cam;
  distorted.dist[0] = 0.1;
  EXPECT_THROW(make_render_camera<double>(distorted, SE3()), Error);
  RasterConfig cfg;
  cfg.alpha_max = 1.0;
  EXPECT_THROW(CpuRasterizer<double>{cfg}, Error);
  cfg = RasterConfig{};
  cfg.sh_degree = 4;
  EXPECT_THROW(CpuRasterizer<double>{cfg}, Error);
}

}  // namespace
}  // namespace chungs
