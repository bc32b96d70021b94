// End to end: random Gaussians optimised with the rasterizer's gradients, the mapping loss and
// sparse Adam reproduce a target image (and inverse depth) rendered from other Gaussians.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/optim/adam.hpp"
#include "chungs/optim/loss.hpp"
#include "chungs/render/cpu/rasterizer.hpp"

namespace chungs {
namespace {

// n Gaussians with centres uniform over the image (plus a margin) at depth z0..z1, isotropic-ish
// footprints of sigma_px pixels, given opacity logits and SH (DC colour; higher bands scaled by `rest`).
GaussianBlock scene(const Camera& cam, size_t n, unsigned seed, double z0, double z1, double sigma_px,
                    double logit, double dc_spread, double rest) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::normal_distribution<double> N(0, 1);
  GaussianBlock b;
  b.resize(n);
  auto& p = b.params;
  for (size_t i = 0; i < n; ++i) {
    const double z = z0 + (z1 - z0) * U(rng), u = -4 + (cam.width + 8) * U(rng),
                 v = -4 + (cam.height + 8) * U(rng);
    p.mean[3 * i] = float((u - cam.cx) / cam.fx * z);
    p.mean[3 * i + 1] = float((v - cam.cy) / cam.fy * z);
    p.mean[3 * i + 2] = float(z);
    for (int k = 0; k < 3; ++k)
      p.log_scale[3 * i + k] = float(std::log(sigma_px * z / cam.fx) + 0.3 * N(rng));
    for (int k = 0; k < 4; ++k) p.rotation[4 * i + k] = float(N(rng));
    p.opacity[i] = float(logit + 0.5 * N(rng));
    for (int k = 0; k < kShCoeffs; ++k)
      for (int c = 0; c < 3; ++c) p.sh[48 * i + 3 * k + c] = float((k == 0 ? dc_spread : rest) * N(rng));
  }
  return b;
}

struct FitResult {
  double first = 0, last = 0;
};

FitResult fit(bool with_depth) {
  const Camera cam(64, 48, 60, 62, 30.5, 25.0);
  const SE3 pose;  // the scene generators place Gaussians in this camera's frame
  const auto rc = make_render_camera<float>(cam, pose);
  CpuRasterizer<float> r;

  GaussianBlock target = scene(cam, 40, 1, 2.0, 4.0, 4.0, 1.5, 0.8, 0.1);
  std::vector<uint32_t> tids(target.size());
  for (size_t i = 0; i < tids.size(); ++i) tids[i] = uint32_t(i);
  const RenderOutput<float> t = r.forward(view_of(target.params), tids, rc);

  GaussianBlock b = scene(cam, 120, 2, 2.0, 4.0, 3.0, 0.0, 0.0, 0.0);
  std::vector<uint32_t> ids(b.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = uint32_t(i);
  AdamConfig adam;
  // A toy scene 3 m away seen by a 60 px focal length: 1e-3 m per step would be 0.02 px; give the
  // positions a rate that moves them ~0.3 px a step, decaying as in the mapper.
  adam.lr_position = 0.015f;
  LossConfig lc;
  lc.lambda_depth = with_depth ? 1.0 : 0.0;
  RenderGrads<float> dl;
  GaussianGrads<float> grads;
  FitResult res;
  const int iterations = 600;
  for (int it = 0; it < iterations; ++it) {
    const RenderOutput<float>& out = r.forward(view_of(b.params), ids, rc);
    const LossTerms terms = mapping_loss(lc, out, t.rgb, with_depth ? &t.inv_depth : nullptr, nullptr, &dl);
    if (it == 0) res.first = terms.total;
    res.last = terms.total;
    r.backward(dl, grads);
    sparse_adam_step(adam, mut_view_of(b.params), adam_state_of(b), ids, out.visible, grads);
  }
  return res;
}

TEST(Fitting, RandomGaussiansRecoverATargetImage) {
  const FitResult f = fit(false);
  std::printf("RGB only: loss %.4f -> %.4f (%.1fx)\n", f.first, f.last, f.first / f.last);
  EXPECT_LT(f.last, f.first / 10);
}

TEST(Fitting, RandomGaussiansRecoverATargetImageAndInverseDepth) {
  const FitResult f = fit(true);
  std::printf("RGB + depth: loss %.4f -> %.4f (%.1fx)\n", f.first, f.last, f.first / f.last);
  EXPECT_LT(f.last, f.first / 10);
}

}  // namespace
}  // namespace chungs
