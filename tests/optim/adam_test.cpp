#include "chungs/optim/adam.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace chungs {
namespace {

GaussianBlock random_block(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> N(0, 1);
  GaussianBlock b;
  b.resize(n);
  for (auto* v : {&b.params.mean, &b.params.log_scale, &b.params.rotation, &b.params.opacity, &b.params.sh})
    for (float& x : *v) x = N(rng);
  return b;
}

GaussianGrads<float> random_grads(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> N(0, 1);
  GaussianGrads<float> g;
  g.resize(n);
  for (auto* v : {&g.mean, &g.log_scale, &g.rotation, &g.opacity, &g.sh})
    for (float& x : *v) x = N(rng);
  return g;
}

// Textbook Adam on one scalar, in double, with its own step count.
struct RefAdam {
  double m = 0, v = 0;
  int t = 0;
  double step(double p, double g, double lr, const AdamConfig& c) {
    ++t;
    m = c.beta1 * m + (1 - c.beta1) * g;
    v = c.beta2 * v + (1 - c.beta2) * g * g;
    const double mh = m / (1 - std::pow(double(c.beta1), t)), vh = v / (1 - std::pow(double(c.beta2), t));
    return p - lr * mh / (std::sqrt(vh) + c.eps);
  }
};

TEST(SparseAdam, MatchesTextbookAdamPerGaussianAndSkipsInvisibleOnes) {
  GaussianBlock b = random_block(6, 1);
  const GaussianBlock before = b;
  AdamConfig cfg;
  cfg.position_lr_floor = 0.995f;  // reached after a few visits: checks decay and floor
  const std::vector<uint32_t> ids{4, 1, 3};
  const std::vector<uint8_t> visible{1, 1, 0};
  // Slot 4 visited 5 times, slot 1 only in the last 2 steps: its bias correction starts afresh.
  RefAdam ref_mean4, ref_sh1_dc, ref_sh1_rest, ref_op4, ref_rot1, ref_scale4;
  double p_mean4 = b.params.mean[3 * 4 + 1], p_sh1_dc = b.params.sh[48 * 1 + 2],
         p_sh1_rest = b.params.sh[48 * 1 + 20];
  double p_op4 = b.params.opacity[4], p_rot1 = b.params.rotation[4 * 1 + 3],
         p_scale4 = b.params.log_scale[3 * 4 + 2];
  double factor4 = 1;
  for (int step = 0; step < 5; ++step) {
    const GaussianGrads<float> g = random_grads(3, 10 + step);
    std::vector<uint8_t> vis = visible;
    if (step < 3) vis[1] = 0;
    sparse_adam_step(cfg, mut_view_of(b.params), adam_state_of(b), ids, vis, g);
    p_mean4 = ref_mean4.step(p_mean4, g.mean[1], cfg.lr_position * factor4, cfg);
    factor4 = std::max(factor4 * cfg.position_decay, double(cfg.position_lr_floor));
    p_op4 = ref_op4.step(p_op4, g.opacity[0], cfg.lr_opacity, cfg);
    p_scale4 = ref_scale4.step(p_scale4, g.log_scale[2], cfg.lr_scale, cfg);
    if (step >= 3) {
      p_sh1_dc = ref_sh1_dc.step(p_sh1_dc, g.sh[48 * 1 + 2], cfg.lr_sh_dc, cfg);
      p_sh1_rest = ref_sh1_rest.step(p_sh1_rest, g.sh[48 * 1 + 20], cfg.lr_sh_rest, cfg);
      p_rot1 = ref_rot1.step(p_rot1, g.rotation[4 * 1 + 3], cfg.lr_rotation, cfg);
    }
  }
  EXPECT_NEAR(b.params.mean[3 * 4 + 1], p_mean4, 1e-6);
  EXPECT_NEAR(b.params.opacity[4], p_op4, 1e-6);
  EXPECT_NEAR(b.params.log_scale[3 * 4 + 2], p_scale4, 1e-6);
  EXPECT_NEAR(b.params.sh[48 * 1 + 2], p_sh1_dc, 1e-6);
  EXPECT_NEAR(b.params.sh[48 * 1 + 20], p_sh1_rest, 1e-7);
  EXPECT_NEAR(b.params.rotation[4 * 1 + 3], p_rot1, 1e-6);
  EXPECT_EQ(b.adam_steps[4], 5u);
  EXPECT_EQ(b.adam_steps[1], 2u);
  EXPECT_FLOAT_EQ(b.lr_position_factor[4], 0.995f);  // 0.998^5 = 0.990 is below the floor
  EXPECT_NEAR(b.lr_position_factor[1], 0.998 * 0.998, 1e-6);
  // Slot 3 was listed but never visible, slots 0, 2 and 5 never listed: untouched.
  for (size_t s : {0u, 2u, 3u, 5u}) {
    EXPECT_EQ(b.adam_steps[s], 0u);
    EXPECT_EQ(b.lr_position_factor[s], 1.0f);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(b.params.mean[3 * s + k], before.params.mean[3 * s + k]);
    for (int k = 0; k < 48; ++k) EXPECT_EQ(b.params.sh[48 * s + k], before.params.sh[48 * s + k]);
    EXPECT_EQ(b.adam_m.opacity[s], 0.0f);
  }
}

TEST(SparseAdam, FirstStepMovesEveryParameterByItsLearningRate) {
  // With bias correction, Adam's first step is lr * sign(g) (|g| >> eps).
  GaussianBlock b = random_block(1, 2);
  const GaussianBlock before = b;
  AdamConfig cfg;
  cfg.lr_position = 5e-5f;
  const GaussianGrads<float> g = random_grads(1, 3);
  sparse_adam_step(cfg, mut_view_of(b.params), adam_state_of(b), std::vector<uint32_t>{0},
                   std::vector<uint8_t>{1}, g);
  auto moved = [](float now, float was, float grad) { return (was - now) * (grad > 0 ? 1 : -1); };
  EXPECT_NEAR(moved(b.params.mean[0], before.params.mean[0], g.mean[0]), 5e-5,
              5e-7);  // float rounding of p ~ 1
  EXPECT_NEAR(moved(b.params.opacity[0], before.params.opacity[0], g.opacity[0]), cfg.lr_opacity, 5e-7);
  EXPECT_NEAR(moved(b.params.log_scale[1], before.params.log_scale[1], g.log_scale[1]), 0.01, 5e-7);
  EXPECT_NEAR(moved(b.params.rotation[2], before.params.rotation[2], g.rotation[2]), 0.002, 5e-7);
  EXPECT_NEAR(moved(b.params.sh[1], before.params.sh[1], g.sh[1]), 0.005, 5e-7);
  EXPECT_NEAR(moved(b.params.sh[40], before.params.sh[40], g.sh[40]), 0.005 / 20, 5e-7);
}

TEST(SparseAdam, RejectsMismatchedInput) {
  GaussianBlock b = random_block(3, 4);
  const GaussianGrads<float> g = random_grads(2, 5);
  const auto p = mut_view_of(b.params);
  const auto st = adam_state_of(b);
  EXPECT_THROW(sparse_adam_step({}, p, st, std::vector<uint32_t>{0, 1}, std::vector<uint8_t>{1}, g), Error);
  EXPECT_THROW(sparse_adam_step({}, p, st, std::vector<uint32_t>{0, 3}, std::vector<uint8_t>{1, 1}, g),
               Error);
  AdamConfig bad;
  bad.beta2 = 1.0f;
  EXPECT_THROW(sparse_adam_step(bad, p, st, std::vector<uint32_t>{0, 1}, std::vector<uint8_t>{1, 1}, g),
               Error);
}

// s holds c's rates with those of opacity, colour (degree 0) and scale times f, the others as given.
void expect_three_rates_scaled(const AdamConfig& s, const AdamConfig& c, float f) {
  EXPECT_FLOAT_EQ(s.lr_opacity, f * c.lr_opacity);
  EXPECT_FLOAT_EQ(s.lr_sh_dc, f * c.lr_sh_dc);
  EXPECT_FLOAT_EQ(s.lr_scale, f * c.lr_scale);
  EXPECT_EQ(s.lr_position, c.lr_position);
  EXPECT_EQ(s.lr_sh_rest, c.lr_sh_rest);
  EXPECT_EQ(s.lr_rotation, c.lr_rotation);
}

TEST(AdamRates, KeyframesTrainedLongerGetSlowerOpacityColourAndScaleRates) {
  // Issue 20: at the reference's 30 steps per keyframe and below the rates are as given; at 300 the
  // three rates are x sqrt(30 / 300); positions, higher SH bands and rotations keep theirs.
  const AdamConfig c;
  EXPECT_EQ(c.reference_steps, 30);
  for (double steps : {-1.0, 0.0, 10.0, 30.0, double(NAN), double(INFINITY)})
    EXPECT_EQ(c.steps_factor(steps), 1.0) << steps;
  EXPECT_NEAR(c.steps_factor(120), 0.5, 1e-12);
  EXPECT_NEAR(c.steps_factor(300), std::sqrt(0.1), 1e-12);
  expect_three_rates_scaled(c.for_steps(120), c, 0.5f);
  // The small-image and the steps factors multiply.
  EXPECT_FLOAT_EQ(c.for_image(310, 94).for_steps(120).lr_opacity, c.lr_opacity);
  AdamConfig off;
  off.reference_steps = 0;
  EXPECT_EQ(off.for_steps(3000).lr_opacity, off.lr_opacity);
  for (double bad : {-1.0, double(NAN), double(INFINITY)}) {
    AdamConfig b;
    b.reference_steps = bad;
    EXPECT_THROW(b.validate(), Error) << bad;
  }
}

TEST(AdamRates, SmallImagesGetFasterOpacityColourAndScaleRates) {
  // Issue 20: at 310x94 (a quarter of the reference's pixels) the three rates double; positions,
  // higher SH bands and rotations keep theirs; at the reference size and above nothing changes.
  const AdamConfig c;
  EXPECT_DOUBLE_EQ(c.small_image_factor(620, 188), 1.0);
  EXPECT_DOUBLE_EQ(c.small_image_factor(1241, 376), 1.0);
  EXPECT_NEAR(c.small_image_factor(310, 94), 2.0, 1e-12);
  EXPECT_DOUBLE_EQ(c.small_image_factor(64, 48), 4.0);  // at most 4x
  expect_three_rates_scaled(c.for_image(310, 94), c, 2.0f);
  AdamConfig off;
  off.small_image_reference_px = 0;
  EXPECT_EQ(off.for_image(64, 48).lr_opacity, off.lr_opacity);
  EXPECT_THROW(c.small_image_factor(0, 48), Error);
  for (double bad : {-1.0, double(NAN), double(INFINITY)}) {
    AdamConfig b;
    b.small_image_reference_px = bad;
    EXPECT_THROW(b.validate(), Error) << bad;
  }
}

TEST(AdamRates, TheOneCameraPositionFactorIsRefusedOutsideItsRange) {
  for (float bad : {0.0f, -1.0f, 101.0f, float(NAN), float(INFINITY)}) {
    AdamConfig b;
    b.multiview_position_factor = bad;
    EXPECT_THROW(b.validate(), Error) << bad;
  }
  AdamConfig ok;
  ok.multiview_position_factor = 1.0f;  // off
  EXPECT_NO_THROW(ok.validate());
}

}  // namespace
}  // namespace chungs
