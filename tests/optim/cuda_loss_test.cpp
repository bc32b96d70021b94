// The fused CUDA mapping loss (L1 + SSIM + inverse-depth L1) against its CPU twin on random images.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cmath>
#include <random>
#include <string>

#include "chungs/cuda/devices.hpp"
#include "chungs/optim/cuda/loss.hpp"

namespace chungs {
namespace {

double rel_norm(const std::vector<float>& a, const std::vector<float>& b) {
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    num += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
    den += double(b[i]) * b[i];
  }
  return std::sqrt(num / den);
}

// A smooth random image plus noise, so SSIM is neither ~0 nor ~1.
Image<float> random_image(int w, int h, int c, std::mt19937& rng, float noise) {
  std::uniform_real_distribution<float> U(0, 1);
  Image<float> img(w, h, c);
  const float fx = 0.1f + 0.2f * U(rng), fy = 0.1f + 0.2f * U(rng);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k)
        img(x, y, k) = 0.5f + 0.3f * std::sin(fx * x + fy * y + k) + noise * (U(rng) - 0.5f);
  return img;
}

TEST(CudaMappingLoss, MatchesCpuTwinWithAndWithoutDepth) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(5);
  cuda::CudaMappingLoss gpu;
  for (int trial = 0; trial < 3; ++trial) {
    SCOPED_TRACE(trial);
    const int w = trial == 0 ? 37 : 131, h = trial == 0 ? 29 : 70;
    RenderOutput<float> r;
    r.rgb = random_image(w, h, 3, rng, 0.2f);
    r.inv_depth = random_image(w, h, 1, rng, 0.3f);
    const Image<float> target = random_image(w, h, 3, rng, 0.2f);
    Image<float> tinv = random_image(w, h, 1, rng, 0.3f);
    Image<uint8_t> mask(w, h, 1);
    for (int i = 0; i < w * h; i += 7) tinv.data()[i] = i % 2 ? 0.f : NAN;  // invalid pixels
    for (auto& m : mask.vec()) m = rng() % 5 != 0;
    LossConfig cfg;
    cfg.lambda_depth = trial == 1 ? 0.0 : 0.5;
    if (trial == 2) cfg.lambda_ssim = 0.0;
    RenderGrads<float> ref;
    const LossTerms want = mapping_loss(cfg, r, target, &tinv, &mask, &ref);

    cuda::DeviceArray<float> drgb(r.rgb.vec()), dinv(r.inv_depth.vec()), dt(target.vec()), dtinv(tinv.vec());
    cuda::DeviceArray<uint8_t> dmask(mask.vec());
    cuda::DeviceRenderOutput out;
    out.width = w, out.height = h, out.rgb = drgb.data(), out.inv_depth = dinv.data();
    const LossTerms got = gpu.evaluate(cfg, out, dt.data(), dtinv.data(), dmask.data());
    EXPECT_NEAR(got.l1, want.l1, 1e-6 * want.l1);
    EXPECT_NEAR(got.ssim, want.ssim, 1e-5);
    EXPECT_NEAR(got.depth, want.depth, 1e-6 * (want.depth + 1e-3));
    EXPECT_EQ(got.depth_pixels, want.depth_pixels);
    EXPECT_NEAR(got.total, want.total, 1e-5 * want.total);
    std::vector<float> g(size_t(3) * w * h);
    cuda::copy_to_host(g.data(), gpu.grads().rgb, g.size() * sizeof(float), "test");
    const double e = rel_norm(g, ref.rgb.vec());
    std::printf("loss %.6f vs %.6f, ssim %.6f vs %.6f, gradient relative error %.2e\n", got.total, want.total,
                got.ssim, want.ssim, e);
    EXPECT_LT(e, 1e-4);
    if (cfg.lambda_depth > 0) {
      ASSERT_NE(gpu.grads().inv_depth, nullptr);
      std::vector<float> gd(size_t(w) * h);
      cuda::copy_to_host(gd.data(), gpu.grads().inv_depth, gd.size() * sizeof(float), "test");
      EXPECT_LT(rel_norm(gd, ref.inv_depth.vec()), 1e-6);
    } else {
      EXPECT_EQ(gpu.grads().inv_depth, nullptr);
    }
  }
}

TEST(CudaMappingLoss, PixelMaskMatchesCpuTwin) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(8);
  cuda::CudaMappingLoss gpu;
  const int w = 97, h = 53;
  RenderOutput<float> r;
  r.rgb = random_image(w, h, 3, rng, 0.2f);
  r.inv_depth = random_image(w, h, 1, rng, 0.3f);
  const Image<float> target = random_image(w, h, 3, rng, 0.2f);
  const Image<float> tinv = random_image(w, h, 1, rng, 0.3f);
  Image<uint8_t> pixels(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) pixels(x, y) = (x / 8 + y / 8) % 3 != 0 && rng() % 7 != 0;
  LossConfig cfg;
  cfg.lambda_depth = 0.5;
  RenderGrads<float> ref;
  mapping_loss(cfg, r, target, &tinv, nullptr, &ref, &pixels);
  cuda::DeviceArray<float> drgb(r.rgb.vec()), dinv(r.inv_depth.vec()), dt(target.vec()), dtinv(tinv.vec());
  cuda::DeviceArray<uint8_t> dpix(pixels.vec());
  cuda::DeviceRenderOutput out;
  out.width = w, out.height = h, out.rgb = drgb.data(), out.inv_depth = dinv.data();
  gpu.evaluate(cfg, out, dt.data(), dtinv.data(), nullptr, true, dpix.data());
  std::vector<float> g(size_t(3) * w * h), gd(size_t(w) * h);
  cuda::copy_to_host(g.data(), gpu.grads().rgb, g.size() * sizeof(float), "test");
  cuda::copy_to_host(gd.data(), gpu.grads().inv_depth, gd.size() * sizeof(float), "test");
  EXPECT_LT(rel_norm(g, ref.rgb.vec()), 1e-4);
  EXPECT_LT(rel_norm(gd, ref.inv_depth.vec()), 1e-6);
  for (size_t i = 0; i < pixels.pixels(); ++i)
    if (!pixels.data()[i]) {
      ASSERT_EQ(g[3 * i], 0.f);
      ASSERT_EQ(gd[i], 0.f);
    }
}

}  // namespace
}  // namespace chungs
#endif
