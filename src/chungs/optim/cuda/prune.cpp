// Host side of the device pruning rule: argument checks and the CPU rule's thresholds, then the
// kernels (prune.cu).
#ifdef CHUNGS_WITH_CUDA
#include "chungs/optim/cuda/prune.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/optim/cuda/prune_launch.hpp"

namespace chungs::cuda {

void CudaPruneSelector::select(const PruneConfig& cfg, const float* opacity, size_t capacity,
                               const uint32_t* ids, size_t n, const float* radius, int image_width,
                               const uint32_t* visits, const uint32_t* places, std::vector<uint32_t>& out) {
  cfg.validate();
  out.clear();
  if (n == 0) return;
  if (n >= 0x7FFFFFFFu || capacity > 0xFFFFFFFFu) fail("CUDA pruning: too many indices (", n, ")");
  if (!opacity || !ids || !places) fail("CUDA pruning: device arrays are missing (null pointer)");
  if (radius && image_width <= 0) fail("pruning: image width must be positive, got ", image_width);
  const bool aged = cfg.min_visits > 0;
  if (aged && !visits) fail("CUDA pruning: min_visits is set but no visit counts were given");
  flags_.resize(n), selected_.resize(n), count_.resize(1);
  // The same float thresholds as the CPU rule.
  detail::PruneLaunch a{opacity,
                        uint32_t(capacity),
                        ids,
                        uint32_t(n),
                        cfg.max_radius_fraction > 0 ? radius : nullptr,  // as the CPU rule: 0 is no size test
                        cfg.max_radius_fraction * float(image_width),
                        cfg.min_opacity > 0 ? std::log(cfg.min_opacity / (1 - cfg.min_opacity)) : -INFINITY,
                        aged ? visits : nullptr,
                        uint32_t(cfg.min_visits),
                        places,
                        flags_.data(),
                        selected_.data(),
                        count_.data()};
  const size_t bytes = detail::prune_temp_bytes(uint32_t(n));
  temp_.reserve(std::max<size_t>(bytes, 1));
  const uint32_t count = detail::launch_prune_select(a, temp_.data(), bytes);
  out.resize(count);
  if (count) copy_to_host(out.data(), selected_.data(), count * sizeof(uint32_t), "pruned places");
  std::sort(out.begin(), out.end());  // they came in the order of ids
}

}  // namespace chungs::cuda
#endif
