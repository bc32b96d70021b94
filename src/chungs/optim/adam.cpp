#include "chungs/optim/adam.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/image/small_image.hpp"

namespace chungs {

void AdamConfig::validate() const {
  for (auto [v, name] : {std::pair{lr_position, "lr_position"},
                         {lr_sh_dc, "lr_sh_dc"},
                         {lr_sh_rest, "lr_sh_rest"},
                         {lr_opacity, "lr_opacity"},
                         {lr_scale, "lr_scale"},
                         {lr_rotation, "lr_rotation"}})
    if (!(v >= 0) || !std::isfinite(v)) fail("Adam config: ", name, " must be >= 0, got ", v);
  if (!(multiview_position_factor > 0 && multiview_position_factor <= 100))
    fail("Adam config: multiview_position_factor must be above 0 and at most 100, got ", multiview_position_factor);
  if (!(position_decay > 0 && position_decay <= 1))
    fail("Adam config: position_decay must be in (0, 1], got ", position_decay);
  if (!(position_lr_floor >= 0 && position_lr_floor <= 1))
    fail("Adam config: position_lr_floor must be in [0, 1], got ", position_lr_floor);
  for (auto [v, name] : {std::pair{beta1, "beta1"}, {beta2, "beta2"}})
    if (!(v >= 0 && v < 1)) fail("Adam config: ", name, " must be in [0, 1), got ", v);
  if (!(eps > 0) || !std::isfinite(eps)) fail("Adam config: eps must be a finite number > 0, got ", eps);
  if (!(small_image_reference_px >= 0) || !std::isfinite(small_image_reference_px))
    fail("Adam config: small_image_reference_px must be >= 0 (0: off), got ", small_image_reference_px);
  if (!(reference_steps >= 0) || !std::isfinite(reference_steps))
    fail("Adam config: reference_steps must be >= 0 (0: off), got ", reference_steps);
}

double AdamConfig::small_image_factor(int width, int height) const {
  return chungs::small_image_factor(small_image_reference_px, width, height);
}

namespace {

AdamConfig with_rates_scaled(const AdamConfig& a, double f) {
  AdamConfig c = a;
  c.lr_opacity = float(a.lr_opacity * f);
  c.lr_sh_dc = float(a.lr_sh_dc * f);
  c.lr_scale = float(a.lr_scale * f);
  return c;
}

}  // namespace

AdamConfig AdamConfig::for_image(int width, int height) const {
  return with_rates_scaled(*this, small_image_factor(width, height));
}

double AdamConfig::steps_factor(double steps_per_keyframe) const {
  if (!(reference_steps > 0) || !(steps_per_keyframe > reference_steps) || !std::isfinite(steps_per_keyframe))
    return 1.0;
  return std::sqrt(reference_steps / steps_per_keyframe);
}

AdamConfig AdamConfig::for_steps(double steps_per_keyframe) const {
  return with_rates_scaled(*this, steps_factor(steps_per_keyframe));
}

AdamState adam_state_of(GaussianBlock& b) {
  b.validate("Adam state");
  return {mut_view_of(b.adam_m), mut_view_of(b.adam_v), b.adam_steps.data(), b.lr_position_factor.data(),
          b.size()};
}

namespace {

struct Step {
  float beta1, beta2, eps, c1, c2;  // c1 = 1 / (1 - beta1^t), c2 = 1 / (1 - beta2^t)

  void apply(float* p, float* m, float* v, const float* g, int n, float lr) const {
    for (int k = 0; k < n; ++k) {
      m[k] = beta1 * m[k] + (1 - beta1) * g[k];
      v[k] = beta2 * v[k] + (1 - beta2) * g[k] * g[k];
      p[k] -= lr * (m[k] * c1) / (std::sqrt(v[k] * c2) + eps);
    }
  }
};

}  // namespace

void sparse_adam_step(const AdamConfig& cfg, const GaussianArraysMut<float>& params, const AdamState& state,
                      std::span<const uint32_t> ids, std::span<const uint8_t> visible,
                      const GaussianGrads<float>& grads) {
  cfg.validate();
  const size_t n = ids.size();
  if (visible.size() != n || grads.size() != n)
    fail("sparse Adam: ", n, " indices but ", visible.size(), " visibility flags and ", grads.size(),
         " gradients");
  if (state.capacity < params.capacity)
    fail("sparse Adam: optimiser state holds ", state.capacity, " slots, parameters ", params.capacity);
  check_indices(GaussianArrays<float>(params), ids.data(), n, "sparse Adam");
  if (n > 0 && (!state.steps || !state.lr_position_factor || !state.m.mean || !state.v.mean))
    fail("sparse Adam: optimiser state arrays are missing");

#pragma omp parallel for schedule(static, 256)
  for (long long jj = 0; jj < (long long)n; ++jj) {
    const size_t j = size_t(jj);
    if (!visible[j]) continue;
    const size_t s = ids[j];
    const uint32_t t = ++state.steps[s];
    const Step st{cfg.beta1, cfg.beta2, cfg.eps, float(1 / (1 - std::pow(double(cfg.beta1), double(t)))),
                  float(1 / (1 - std::pow(double(cfg.beta2), double(t))))};
    float& factor = state.lr_position_factor[s];
    st.apply(params.mean + 3 * s, state.m.mean + 3 * s, state.v.mean + 3 * s, grads.mean.data() + 3 * j, 3,
             cfg.lr_position * factor);
    factor = std::max(factor * cfg.position_decay, cfg.position_lr_floor);
    st.apply(params.log_scale + 3 * s, state.m.log_scale + 3 * s, state.v.log_scale + 3 * s,
             grads.log_scale.data() + 3 * j, 3, cfg.lr_scale);
    st.apply(params.rotation + 4 * s, state.m.rotation + 4 * s, state.v.rotation + 4 * s,
             grads.rotation.data() + 4 * j, 4, cfg.lr_rotation);
    st.apply(params.opacity + s, state.m.opacity + s, state.v.opacity + s, grads.opacity.data() + j, 1,
             cfg.lr_opacity);
    const size_t o = size_t(kShFloats) * s, og = size_t(kShFloats) * j;
    st.apply(params.sh + o, state.m.sh + o, state.v.sh + o, grads.sh.data() + og, 3, cfg.lr_sh_dc);
    st.apply(params.sh + o + 3, state.m.sh + o + 3, state.v.sh + o + 3, grads.sh.data() + og + 3,
             kShFloats - 3, cfg.lr_sh_rest);
  }
}

}  // namespace chungs
