// Host side of the fused CUDA sparse Adam: argument checks, then the kernel (adam.cu).
#ifdef CHUNGS_WITH_CUDA
#include "chungs/optim/cuda/adam.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/optim/cuda/adam_launch.hpp"

namespace chungs::cuda {

void sparse_adam_step(const AdamConfig& cfg, const GaussianArraysMut<float>& params, const AdamState& state,
                      const uint32_t* ids, const uint8_t* visible, size_t n,
                      const DeviceGaussianGrads& grads, bool ids_checked) {
  cfg.validate();
  if (grads.count != n) fail("CUDA sparse Adam: ", n, " indices but ", grads.count, " gradients");
  if (n == 0) return;
  if (n >= 0xFFFFFFFFu / 32) fail("CUDA sparse Adam: too many indices (", n, ")");
  if (!ids || !visible || !state.steps || !state.lr_position_factor || !state.m.mean || !state.v.mean ||
      !params.mean || !grads.mean)
    fail("CUDA sparse Adam: device arrays are missing (null pointer)");
  detail::AdamLaunch a{{params.mean, params.log_scale, params.rotation, params.opacity, params.sh},
                       {state.m.mean, state.m.log_scale, state.m.rotation, state.m.opacity, state.m.sh},
                       {state.v.mean, state.v.log_scale, state.v.rotation, state.v.opacity, state.v.sh},
                       {grads.mean, grads.log_scale, grads.rotation, grads.opacity, grads.sh},
                       state.steps,
                       state.lr_position_factor,
                       ids,
                       visible,
                       uint32_t(n),
                       std::min(params.capacity, state.capacity),
                       cfg.beta1,
                       cfg.beta2,
                       cfg.eps,
                       {cfg.lr_position, cfg.lr_scale, cfg.lr_rotation, cfg.lr_opacity, cfg.lr_sh_rest},
                       cfg.lr_sh_dc,
                       cfg.position_decay,
                       cfg.position_lr_floor,
                       std::log(double(cfg.beta1)),
                       std::log(double(cfg.beta2))};
  const uint32_t bad = detail::launch_sparse_adam(a, !ids_checked);
  if (bad != 0xFFFFFFFFu)
    fail("CUDA sparse Adam: index ", bad, " is at or above the ", a.capacity,
         " slots of the parameters/state");
}

}  // namespace chungs::cuda
#endif
