// Internal: the fused Adam kernel's arguments as plain C++17 data, so that adam.cu need not see
// chungs/optim/adam.hpp (C++20, while .cu files compile as C++17).
#pragma once
#include <cstddef>
#include <cstdint>

namespace chungs::cuda::detail {

// Parameter kinds in order: mean, log_scale, rotation, opacity, sh.
struct AdamLaunch {
  float* p[5];
  float* m[5];
  float* v[5];
  const float* g[5];
  uint32_t* steps;
  float* factor;
  const uint32_t* ids;
  const uint8_t* visible;
  uint32_t n;
  size_t capacity;
  float beta1, beta2, eps;
  float lr[5];  // per kind; lr[0] before the slot's factor, lr[4] for the SH rest
  float lr_sh_dc, decay, floor;
  double log_beta1, log_beta2;  // ln beta1, ln beta2 (the bias corrections)
};

// Runs the step; with check, waits for it and returns the smallest j whose slot is out of range (those
// are skipped), else launches only and returns 0xFFFFFFFF. Throws Error on a CUDA failure.
uint32_t launch_sparse_adam(const AdamLaunch& a, bool check = true);

}  // namespace chungs::cuda::detail
