// Random Gaussian blocks for store and residency tests: every array filled with distinct,
// non-zero values of realistic magnitude, so a swapped, lost or zeroed array is always noticed.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

#include "chungs/gaussians/gaussian_block.hpp"

namespace chungs::test {

inline GaussianBlock random_block(size_t n, uint64_t seed, float centre_x = 0, float centre_y = 0,
                                  float centre_z = 0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> g(0.f, 1.f);
  std::uniform_real_distribution<float> u(-4.9f, 4.9f);
  GaussianBlock b;
  b.sh_degree = 3;
  b.resize(n);
  auto fill = [&](GaussianParams& p, float scale) {
    for (size_t i = 0; i < n; ++i) {
      const float c[3] = {centre_x, centre_y, centre_z};
      for (int k = 0; k < 3; ++k) p.mean[3 * i + k] = c[k] + scale * u(rng);
      for (int k = 0; k < 3; ++k) p.log_scale[3 * i + k] = scale * (-3.f + 0.5f * g(rng));
      for (int k = 0; k < 4; ++k) p.rotation[4 * i + k] = scale * g(rng);
      p.opacity[i] = scale * g(rng);
      for (int k = 0; k < kShFloats; ++k) p.sh[size_t(kShFloats) * i + k] = scale * (k < 3 ? g(rng) : 0.05f * g(rng));
    }
  };
  fill(b.params, 1.f);
  fill(b.adam_m, 1e-3f);
  fill(b.adam_v, 1e-6f);
  for (auto& v : b.adam_v.opacity) v = std::abs(v);
  for (size_t i = 0; i < n; ++i) {
    b.adam_steps[i] = uint32_t(rng() % 1000 + 1);
    b.created_by_keyframe[i] = uint32_t(rng() % 5000);
    b.created_at_step[i] = uint32_t(rng());
    b.lr_position_factor[i] = 0.5f + 0.5f * std::abs(g(rng));
  }
  return b;
}

// Bitwise equality of every array (NaN-safe, and -0 differs from +0).
inline bool same_bits(const GaussianBlock& a, const GaussianBlock& b) {
  auto eq = [](const auto& x, const auto& y) {
    return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof x[0]) == 0);
  };
  auto eqp = [&](const GaussianParams& x, const GaussianParams& y) {
    return eq(x.mean, y.mean) && eq(x.log_scale, y.log_scale) && eq(x.rotation, y.rotation) &&
           eq(x.opacity, y.opacity) && eq(x.sh, y.sh);
  };
  return a.sh_degree == b.sh_degree && eqp(a.params, b.params) && eqp(a.adam_m, b.adam_m) &&
         eqp(a.adam_v, b.adam_v) && eq(a.adam_steps, b.adam_steps) &&
         eq(a.created_by_keyframe, b.created_by_keyframe) && eq(a.created_at_step, b.created_at_step) &&
         eq(a.lr_position_factor, b.lr_position_factor);
}

}  // namespace chungs::test
