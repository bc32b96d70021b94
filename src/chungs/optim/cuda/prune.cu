// One thread per view entry flags it with the rule of select_for_pruning; cub's flagged select of the
// entries' places keeps the order of the view, so the list matches the CPU twin's entry for entry.
#include <cuda_runtime.h>

#include <cub/device/device_select.cuh>

#include "chungs/common/error.hpp"
#include "chungs/optim/cuda/prune_launch.hpp"

namespace chungs::cuda::detail {

namespace {

__global__ void flag_kernel(PruneLaunch a) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= a.n) return;
  const uint32_t id = a.ids[j];
  if (id >= a.capacity) {
    a.flags[j] = 0;
    return;
  }
  // Written as the CPU rule so that NaN (a diverged Gaussian) is pruned too.
  const float o = a.opacity[id];
  const bool young = a.visits && isfinite(o) && a.visits[id] < a.min_visits;
  const bool faint = !young && !(o >= a.min_logit);
  const bool huge = a.radius && !(a.radius[j] <= a.max_radius);
  a.flags[j] = (faint || huge) ? 1 : 0;
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("CUDA pruning: ", what, ": ", cudaGetErrorString(e));
}

}  // namespace

size_t prune_temp_bytes(uint32_t n) {
  size_t bytes = 0;
  check(cub::DeviceSelect::Flagged(nullptr, bytes, static_cast<const uint32_t*>(nullptr),
                                   static_cast<const uint8_t*>(nullptr), static_cast<uint32_t*>(nullptr),
                                   static_cast<uint32_t*>(nullptr), int(n)),
        "select size");
  return bytes;
}

uint32_t launch_prune_select(const PruneLaunch& a, void* temp, size_t temp_bytes) {
  flag_kernel<<<unsigned((size_t(a.n) + 255) / 256), 256>>>(a);
  check(cudaGetLastError(), "flag launch");
  check(cub::DeviceSelect::Flagged(temp, temp_bytes, a.places, a.flags, a.selected, a.count, int(a.n)),
        "select");
  uint32_t count = 0;
  check(cudaMemcpy(&count, a.count, sizeof count, cudaMemcpyDeviceToHost), "count");
  return count;
}

}  // namespace chungs::cuda::detail
