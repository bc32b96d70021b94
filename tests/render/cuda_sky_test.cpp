// Parity of the CUDA sky with its CPU twin on a random texture, camera and render: the composed
// image, the alpha gradient, and the texture after an Adam step. Skipped where no CUDA device is
// present.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include <random>

#include "chungs/render/cuda/sky.hpp"
#include "chungs/render/sky.hpp"
#include "cuda_test_support.hpp"
#include "random_scene.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

using test::rel_error;

TEST(CudaSky, MatchesTheCpuTwin) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> U(0, 1);
  const test::RandomScene scene = test::make_random_scene(4, 1, 173, 91);
  const RenderCamera<float> cam = make_render_camera<float>(scene.camera, scene.pose);
  const double R[9] = {0.36, 0.48, -0.8, -0.8, 0.6, 0, 0.48, 0.64, 0.6};
  SkyConfig cfg;
  cfg.width = 64;
  cfg.height = 32;
  SkyTexture sky = make_sky(cfg, R);
  for (float& v : sky.rgb) v = U(rng);
  ImageF rgb(cam.width, cam.height, 3), alpha(cam.width, cam.height, 1), grad(cam.width, cam.height, 3);
  for (float& v : rgb.vec()) v = U(rng);
  for (float& v : alpha.vec()) v = U(rng) < 0.3f ? 1.f : U(rng);  // some pixels fully covered
  for (float& v : grad.vec()) v = 2 * U(rng) - 1;

  cuda::CudaSky gpu;
  gpu.upload(sky);
  const cuda::DeviceArray<float> d_rgb(rgb.vec()), d_alpha(alpha.vec()), d_grad(grad.vec());
  cuda::DeviceRenderOutput r;
  r.width = cam.width, r.height = cam.height, r.rgb = d_rgb.data(), r.alpha = d_alpha.data();
  std::vector<float> composed(rgb.vec().size()), grad_alpha(alpha.vec().size());
  cuda::copy_to_host(composed.data(), gpu.compose(r, cam), composed.size() * sizeof(float), "composed");
  cuda::copy_to_host(grad_alpha.data(), gpu.backward(d_grad.data(), r, cam),
                     grad_alpha.size() * sizeof(float), "grad alpha");
  gpu.adam_step(0.05);
  SkyTexture after;
  gpu.download(after);

  ImageF sky_px, want = rgb, want_galpha;
  sky_colours(sky, cam, sky_px);
  compose_sky(sky_px, alpha, want);
  std::vector<float> texel_grad(3 * sky.texels(), 0.f);
  sky_backward(sky, cam, sky_px, alpha, grad, want_galpha, texel_grad);
  sky_adam_step(sky, texel_grad, 0.05);
  EXPECT_LT(rel_error(composed, want.vec()), 1e-6);
  EXPECT_LT(rel_error(grad_alpha, want_galpha.vec()), 1e-6);
  EXPECT_LT(rel_error(after.rgb, sky.rgb), 1e-5);
  EXPECT_LT(rel_error(after.m1, sky.m1), 1e-4);  // atomics sum in another order
  EXPECT_EQ(after.updates, sky.updates);
  size_t moved = 0;
  for (uint32_t u : sky.updates) moved += u;
  EXPECT_GT(moved, 100u) << "the camera must see part of the texture";
}

}  // namespace
}  // namespace chungs
#endif
