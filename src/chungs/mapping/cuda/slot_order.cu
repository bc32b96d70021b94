// cub's radix sort of the slot list over the bits the pool's capacity needs (21 for 2 M slots: three
// passes), the places riding along as values.
#include <cuda_runtime.h>

#include <algorithm>
#include <climits>
#include <cub/device/device_radix_sort.cuh>

#include "chungs/common/error.hpp"
#include "chungs/mapping/cuda/slot_order.hpp"

namespace chungs::cuda {

namespace {

__global__ void sequence_kernel(uint32_t* out, uint32_t n) {
  for (uint32_t i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) out[i] = i;
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("CUDA slot order: ", what, ": ", cudaGetErrorString(e));
}

}  // namespace

void SlotOrder::sort(const uint32_t* ids, size_t n, size_t capacity) {
  if (n == 0) return;
  if (n > size_t(INT_MAX)) fail("CUDA slot order: ", n, " slots are more than one sort takes");
  if (!ids) fail("CUDA slot order: no slot list (null pointer)");
  sorted_.resize(n), places_.resize(n);
  if (sequence_n_ < n) {
    sequence_n_ = std::max(n, sequence_n_ + sequence_n_ / 4);  // fewer refills while the views grow
    sequence_.resize(sequence_n_);
    sequence_kernel<<<unsigned(std::min<size_t>((sequence_n_ + 255) / 256, 4096)), 256>>>(
        sequence_.data(), uint32_t(sequence_n_));
    check(cudaGetLastError(), "sequence launch");
  }
  int bits = 1;
  while (bits < 32 && (size_t(1) << bits) < capacity) ++bits;
  size_t bytes = 0;
  check(cub::DeviceRadixSort::SortPairs(nullptr, bytes, ids, sorted_.data(), sequence_.data(), places_.data(),
                                        int(n), 0, bits),
        "sort size");
  temp_.reserve(std::max<size_t>(bytes, 1));
  check(cub::DeviceRadixSort::SortPairs(temp_.data(), bytes, ids, sorted_.data(), sequence_.data(),
                                        places_.data(), int(n), 0, bits),
        "sort");
}

}  // namespace chungs::cuda
