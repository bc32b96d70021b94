// One warp per Gaussian: each lane updates up to two of its 59 floats, so every parameter array is
// read and written in contiguous runs; lane 0 owns the step count and the position factor.
#include <cuda_runtime.h>

#include "chungs/common/error.hpp"
#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/optim/cuda/adam_launch.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda::detail {

namespace {

__global__ void adam_kernel(AdamLaunch a, uint32_t* __restrict__ bad) {
  const uint32_t j = (blockIdx.x * blockDim.x + threadIdx.x) >> 5;
  const int lane = threadIdx.x & 31;
  if (j >= a.n || !a.visible[j]) return;  // warp-uniform
  const uint32_t s = a.ids[j];
  if (s >= a.capacity) {
    if (lane == 0 && bad) atomicMin(bad, j);
    return;
  }
  // Lane 0 reads the step count and computes the bias corrections for the warp. As the CPU twin: in
  // double, then rounded. beta^t as exp(t ln beta): a double pow per Gaussian had been a large share
  // of the kernel; both agree to a few double ulps, far below the float the factors are rounded to.
  uint32_t t = 0;
  float f = 0, c1 = 0, c2 = 0;
  if (lane == 0) {
    t = a.steps[s] + 1;
    f = a.factor[s];
    c1 = float(1 / (1 - exp(double(t) * a.log_beta1)));
    c2 = float(1 / (1 - exp(double(t) * a.log_beta2)));
  }
  t = __shfl_sync(0xffffffffu, t, 0);
  f = __shfl_sync(0xffffffffu, f, 0);
  c1 = __shfl_sync(0xffffffffu, c1, 0);
  c2 = __shfl_sync(0xffffffffu, c2, 0);
#pragma unroll
  for (int h = 0; h < 2; ++h) {
    const int e = lane + 32 * h;  // 0..2 mean, 3..5 log_scale, 6..9 rotation, 10 opacity, 11..58 sh
    if (e >= kParamFloats) break;
    const int kind = e < 3 ? 0 : e < 6 ? 1 : e < 10 ? 2 : e < 11 ? 3 : 4;
    const int first = kind == 0 ? 0 : kind == 1 ? 3 : kind == 2 ? 6 : kind == 3 ? 10 : 11;
    const int width = kind == 0 ? 3 : kind == 1 ? 3 : kind == 2 ? 4 : kind == 3 ? 1 : kShFloats;
    const int k = e - first;
    const size_t ip = size_t(width) * s + k, ig = size_t(width) * j + k;
    float lr = kind == 4 ? (k < 3 ? a.lr_sh_dc : a.lr[4]) : a.lr[kind];
    if (kind == 0) lr *= f;
    const float g = a.g[kind][ig];
    const float m = a.beta1 * a.m[kind][ip] + (1 - a.beta1) * g;
    const float v = a.beta2 * a.v[kind][ip] + (1 - a.beta2) * g * g;
    a.m[kind][ip] = m;
    a.v[kind][ip] = v;
    a.p[kind][ip] -= lr * (m * c1) / (sqrtf(v * c2) + a.eps);
  }
  if (lane == 0) {
    a.steps[s] = t;
    a.factor[s] = fmaxf(f * a.decay, a.floor);
  }
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("CUDA sparse Adam: ", what, ": ", cudaGetErrorString(e));
}

}  // namespace

uint32_t launch_sparse_adam(const AdamLaunch& a, bool check_ids) {
  // The out-of-range flag; one per thread so concurrent optimisers do not share it.
  thread_local DeviceArray<uint32_t> flag(1);
  uint32_t host_bad = 0xFFFFFFFFu;
  if (check_ids) check(cudaMemsetAsync(flag.data(), 0xFF, sizeof(uint32_t)), "memset");
  const unsigned threads = 256, blocks = unsigned((size_t(a.n) * 32 + threads - 1) / threads);
  adam_kernel<<<blocks, threads>>>(a, check_ids ? flag.data() : nullptr);
  check(cudaGetLastError(), "launch");
  if (check_ids) check(cudaMemcpy(&host_bad, flag.data(), sizeof host_bad, cudaMemcpyDeviceToHost), "step");
  return host_bad;
}

}  // namespace chungs::cuda::detail
