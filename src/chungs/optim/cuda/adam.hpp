// Fused sparse Adam on the GPU: the same step as chungs::sparse_adam_step (its CPU twin) on
// parameters, moments and gradients in device memory, one kernel for all parameter kinds.
// Include only from C++ files: no CUDA headers here.
#pragma once
#include <cstddef>
#include <cstdint>

#include "chungs/optim/adam.hpp"
#include "chungs/render/cuda/rasterizer.hpp"

namespace chungs::cuda {

// One step for Gaussians ids[j] with visible[j] != 0 using gradient entry j. params, state, ids,
// visible and grads are device pointers (state.steps and state.lr_position_factor too); ids must be
// distinct. Throws Error naming the first index at or above the capacity of params or state (those
// entries are left untouched) or when grads.count differs from n.
void sparse_adam_step(const AdamConfig& config, const GaussianArraysMut<float>& params,
                      const AdamState& state, const uint32_t* ids, const uint8_t* visible, size_t n,
                      const DeviceGaussianGrads& grads);

}  // namespace chungs::cuda
