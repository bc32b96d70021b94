#include <cuda_runtime.h>

#include <algorithm>

#include "chungs/mapping/cuda/target_cache.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda::detail {

namespace {

__global__ void expand_kernel(const uint8_t* __restrict__ color, int channels, const float* __restrict__ depth,
                              size_t pixels, float* __restrict__ rgb, float* __restrict__ inv,
                              uint8_t* __restrict__ mask) {
  for (size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x; i < pixels; i += size_t(gridDim.x) * blockDim.x) {
    for (int k = 0; k < 3; ++k) rgb[3 * i + k] = color[i * channels + min(k, channels - 1)] / 255.0f;
    if (depth) {
      const float d = depth[i];
      const bool ok = d > 0 && isfinite(d);
      inv[i] = ok ? 1.f / d : 0.f;
      mask[i] = ok ? 1 : 0;
    }
  }
}

}  // namespace

void launch_expand_targets(const uint8_t* color, int channels, const float* depth, size_t pixels, float* rgb,
                           float* inv, uint8_t* mask) {
  if (pixels == 0) return;
  const unsigned blocks = unsigned(std::min<size_t>((pixels + 255) / 256, 4096));
  expand_kernel<<<blocks, 256>>>(color, channels, depth, pixels, rgb, inv, mask);
  check_last("expanding step targets");
}

}  // namespace chungs::cuda::detail
