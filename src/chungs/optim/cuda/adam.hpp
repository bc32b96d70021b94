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
// entries are left untouched) or when grads.count differs from n. ids_checked: the caller has already
// refused out-of-range ids (the rasterizer's forward of the same list does), so the step only launches
// and the host does not wait for the device; such entries are still skipped.
void sparse_adam_step(const AdamConfig& config, const GaussianArraysMut<float>& params,
                      const AdamState& state, const uint32_t* ids, const uint8_t* visible, size_t n,
                      const DeviceGaussianGrads& grads, bool ids_checked = false);

}  // namespace chungs::cuda
