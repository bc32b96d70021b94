// One warp per Gaussian: each lane updates up to two of its 59 floats, so every parameter array is
// read and written in contiguous runs; lane 0 writes the step count and the position factor back.
// Every load of the Gaussian is issued before the bias corrections are worked out, and every lane
// works them out itself: lane 0 alone, then shuffles, had put two double exponentials between the
// step count's load and the parameters' (the kernel was latency-bound at half the DRAM it could use).
#include <cuda_runtime.h>

#include "chungs/common/error.hpp"
#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/optim/cuda/adam_launch.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda::detail {

namespace {

// Element e of a Gaussian's 59 floats: 0..2 mean, 3..5 log_scale, 6..9 rotation, 10 opacity, 11..58 sh.
struct Element {
  int kind, k, width;
};
__device__ __forceinline__ Element element(int e) {
  const int kind = e < 3 ? 0 : e < 6 ? 1 : e < 10 ? 2 : e < 11 ? 3 : 4;
  const int first = kind == 0 ? 0 : kind == 1 ? 3 : kind == 2 ? 6 : kind == 3 ? 10 : 11;
  const int width = kind == 0 ? 3 : kind == 1 ? 3 : kind == 2 ? 4 : kind == 3 ? 1 : kShFloats;
  return {kind, e - first, width};
}

__global__ void adam_kernel(AdamLaunch a, uint32_t* __restrict__ bad) {
  const uint32_t j = (blockIdx.x * blockDim.x + threadIdx.x) >> 5;
  const int lane = threadIdx.x & 31;
  if (j >= a.n || !a.visible[j]) return;  // warp-uniform
  const uint32_t s = a.ids[j];
  if (s >= a.capacity) {
    if (lane == 0 && bad) atomicMin(bad, j);
    return;
  }
  const uint32_t t = a.steps[s] + 1;
  const float f = a.factor[s];
  float g[2] = {0, 0}, m[2] = {0, 0}, v[2] = {0, 0}, p[2] = {0, 0};
#pragma unroll
  for (int h = 0; h < 2; ++h) {
    const int e = lane + 32 * h;
    if (e >= kParamFloats) break;
    const Element el = element(e);
    const size_t ip = size_t(el.width) * s + el.k, ig = size_t(el.width) * j + el.k;
    g[h] = a.g[el.kind][ig], m[h] = a.m[el.kind][ip], v[h] = a.v[el.kind][ip], p[h] = a.p[el.kind][ip];
  }
  // As the CPU twin: in double, then rounded; beta^t as exp(t ln beta) (a double pow per Gaussian had
  // been a large share of the kernel; both agree to a few double ulps, far below float rounding).
  const float c1 = float(1 / (1 - exp(double(t) * a.log_beta1)));
  const float c2 = float(1 / (1 - exp(double(t) * a.log_beta2)));
#pragma unroll
  for (int h = 0; h < 2; ++h) {
    const int e = lane + 32 * h;
    if (e >= kParamFloats) break;
    const Element el = element(e);
    const size_t ip = size_t(el.width) * s + el.k;
    float lr = el.kind == 4 ? (el.k < 3 ? a.lr_sh_dc : a.lr[4]) : a.lr[el.kind];
    if (el.kind == 0) lr *= f;
    const float mn = a.beta1 * m[h] + (1 - a.beta1) * g[h];
    const float vn = a.beta2 * v[h] + (1 - a.beta2) * g[h] * g[h];
    a.m[el.kind][ip] = mn;
    a.v[el.kind][ip] = vn;
    a.p[el.kind][ip] = p[h] - lr * (mn * c1) / (sqrtf(vn * c2) + a.eps);
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
