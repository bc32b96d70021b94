#include <cuda_runtime.h>

#include "chungs/mapping/cuda/device_memory.hpp"

namespace chungs::cuda {

bool device_memory_info(size_t& free_bytes, size_t& total_bytes) {
  size_t f = 0, t = 0;
  if (cudaMemGetInfo(&f, &t) != cudaSuccess) {
    cudaGetLastError();  // the failure is reported by the return value, not left for the next call
    return false;
  }
  free_bytes = f;
  total_bytes = t;
  return true;
}

}  // namespace chungs::cuda
