// Fused mapping loss: one kernel per 16x16 tile and channel computes the L1 term and its gradient,
// the five SSIM moments (separable 11x11 Gaussian from shared memory, zero padding as the CPU twin)
// and the per-pixel SSIM partials; a second pass blurs the partials (the blur is self-adjoint) into
// the gradient; two small kernels do the inverse-depth L1.
#include <cuda_runtime.h>

#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/optim/cuda/loss_launch.hpp"

namespace chungs::cuda::detail {

namespace {

constexpr int kR = 5, kT = 16, kS = kT + 2 * kR;  // window radius, tile, tile with halo
constexpr float kC1 = 0.01f * 0.01f, kC2 = 0.03f * 0.03f;

struct Window {
  float w[2 * kR + 1];
};

// Adds the block's sum of v to one of kLossSpread partial sums of quantity `which`, chosen by the block:
// one double atomic a warp on a single address (44 k of them for a KITTI-sized SSIM) had made the loss
// kernels wait on each other's atomics (the SSIM forward 156 us, the depth sum 48 us on an H100).
// finish_sums_kernel adds the partials up. Every thread of the block must call it.
__device__ void block_sum_add(double* partials, int which, float v) {
  __shared__ float part[32];
#pragma unroll
  for (int o = 16; o > 0; o >>= 1) v += __shfl_xor_sync(0xffffffffu, v, o);
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31, warps = (blockDim.x + 31) >> 5;
  __syncthreads();  // part[] of an earlier call is read
  if (lane == 0) part[warp] = v;
  __syncthreads();
  if (warp != 0) return;
  float s = lane < warps ? part[lane] : 0.f;
#pragma unroll
  for (int o = 16; o > 0; o >>= 1) s += __shfl_xor_sync(0xffffffffu, s, o);
  if (lane == 0 && s != 0.f) {
    const unsigned b = blockIdx.x + gridDim.x * (blockIdx.y + gridDim.y * blockIdx.z);
    atomicAdd(&partials[which * kLossSpread + b % kLossSpread], double(s));
  }
}

__global__ void finish_sums_kernel(const double* __restrict__ partials, double* __restrict__ sums) {
  const int q = threadIdx.x;
  if (q >= 4) return;
  double s = 0;
  for (int i = 0; i < kLossSpread; ++i) s += partials[q * kLossSpread + i];
  sums[q] = s;
}

__global__ void __launch_bounds__(256) ssim_forward_kernel(LossLaunch a, Window win) {
  __shared__ float sx[kS][kS + 1], sy[kS][kS + 1];
  __shared__ float h[5][kS][kT + 1];
  const int W = a.width, H = a.height, c = blockIdx.z, t = threadIdx.x;
  const int lx = t % kT, ly = t / kT;
  const int px = blockIdx.x * kT + lx, py = blockIdx.y * kT + ly;
  const bool inside = px < W && py < H;
  const size_t plane = size_t(W) * H, p = size_t(py) * W + px;

  float l1 = 0.f;
  if (inside) {
    const float d = a.rgb[3 * p + c] - a.target_rgb[3 * p + c];
    l1 = fabsf(d);
    if (a.want_grads) {
      const float step = a.l1_weight / float(3 * plane);
      a.grad_rgb[3 * p + c] = d > 0 ? step : (d < 0 ? -step : 0.f);
    }
  }
  block_sum_add(a.partials, 0, l1);
  if (a.ssim_weight <= 0.f) return;

  const int x0 = blockIdx.x * kT - kR, y0 = blockIdx.y * kT - kR;
  for (int i = t; i < kS * kS; i += blockDim.x) {
    const int r = i / kS, col = i % kS, gx = x0 + col, gy = y0 + r;
    const bool in = gx >= 0 && gx < W && gy >= 0 && gy < H;
    const size_t q = size_t(gy) * W + gx;
    sx[r][col] = in ? a.rgb[3 * q + c] : 0.f;
    sy[r][col] = in ? a.target_rgb[3 * q + c] : 0.f;
  }
  __syncthreads();
  for (int i = t; i < kS * kT; i += blockDim.x) {
    const int r = i / kT, col = i % kT;
    float m[5] = {0, 0, 0, 0, 0};
#pragma unroll
    for (int k = 0; k <= 2 * kR; ++k) {
      const float x = sx[r][col + k], y = sy[r][col + k], w = win.w[k];
      m[0] += w * x, m[1] += w * y, m[2] += w * (x * x), m[3] += w * (y * y), m[4] += w * (x * y);
    }
#pragma unroll
    for (int q = 0; q < 5; ++q) h[q][r][col] = m[q];
  }
  __syncthreads();
  float m[5] = {0, 0, 0, 0, 0};
#pragma unroll
  for (int k = 0; k <= 2 * kR; ++k)
#pragma unroll
    for (int q = 0; q < 5; ++q) m[q] += win.w[k] * h[q][ly + k][lx];
  float S = 0.f;
  if (inside) {
    const float mx = m[0], my = m[1], exx = m[2], eyy = m[3], exy = m[4];
    const float A1 = 2 * mx * my + kC1, A2 = 2 * (exy - mx * my) + kC2;
    const float B1 = mx * mx + my * my + kC1, B2 = (exx - mx * mx) + (eyy - my * my) + kC2;
    S = A1 * A2 / (B1 * B2);
    if (a.want_grads) {
      // d(-ls * mean SSIM) / d(mu_x, E[x^2], E[xy]) at this pixel, blurred back in the second pass.
      const float up = -a.ssim_weight / float(3 * plane);
      const size_t o = size_t(c) * plane + p;
      a.ssim_planes[o] = up * S * (2 * my / A1 - 2 * my / A2 - 2 * mx / B1 + 2 * mx / B2);
      a.ssim_planes[3 * plane + o] = up * (-S / B2);
      a.ssim_planes[6 * plane + o] = up * (2 * S / A2);
    }
  }
  block_sum_add(a.partials, 1, S);
}

__global__ void __launch_bounds__(256) ssim_backward_kernel(LossLaunch a, Window win) {
  __shared__ float sg[3][kS][kS + 1];
  __shared__ float h[3][kS][kT + 1];
  const int W = a.width, H = a.height, c = blockIdx.z, t = threadIdx.x;
  const int lx = t % kT, ly = t / kT;
  const int px = blockIdx.x * kT + lx, py = blockIdx.y * kT + ly;
  const size_t plane = size_t(W) * H;
  const int x0 = blockIdx.x * kT - kR, y0 = blockIdx.y * kT - kR;
  for (int i = t; i < kS * kS; i += blockDim.x) {
    const int r = i / kS, col = i % kS, gx = x0 + col, gy = y0 + r;
    const bool in = gx >= 0 && gx < W && gy >= 0 && gy < H;
    const size_t o = size_t(c) * plane + size_t(gy) * W + gx;
#pragma unroll
    for (int q = 0; q < 3; ++q) sg[q][r][col] = in ? a.ssim_planes[3 * q * plane + o] : 0.f;
  }
  __syncthreads();
  for (int i = t; i < kS * kT; i += blockDim.x) {
    const int r = i / kT, col = i % kT;
    float m[3] = {0, 0, 0};
#pragma unroll
    for (int k = 0; k <= 2 * kR; ++k)
#pragma unroll
      for (int q = 0; q < 3; ++q) m[q] += win.w[k] * sg[q][r][col + k];
#pragma unroll
    for (int q = 0; q < 3; ++q) h[q][r][col] = m[q];
  }
  __syncthreads();
  if (px >= W || py >= H) return;
  float b[3] = {0, 0, 0};
#pragma unroll
  for (int k = 0; k <= 2 * kR; ++k)
#pragma unroll
    for (int q = 0; q < 3; ++q) b[q] += win.w[k] * h[q][ly + k][lx];
  const size_t p = size_t(py) * W + px;
  const float x = a.rgb[3 * p + c], y = a.target_rgb[3 * p + c];
  a.grad_rgb[3 * p + c] += b[0] + 2 * x * b[1] + y * b[2];
}

__device__ __forceinline__ bool depth_valid(const LossLaunch& a, size_t i) {
  const float t = a.target_inv_depth[i];
  return isfinite(t) && t > 0 && (!a.depth_mask || a.depth_mask[i] != 0);
}

__global__ void depth_sum_kernel(LossLaunch a) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const size_t n = size_t(a.width) * a.height;
  float d = 0.f, cnt = 0.f;
  if (i < n && depth_valid(a, i)) {
    d = fabsf(a.inv_depth[i] - a.target_inv_depth[i]);
    cnt = 1.f;
  }
  block_sum_add(a.partials, 2, d);
  block_sum_add(a.partials, 3, cnt);
}

__global__ void depth_grad_kernel(LossLaunch a) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const size_t n = size_t(a.width) * a.height;
  if (i >= n) return;
  const double count = a.sums[3];
  float g = 0.f;
  if (count > 0 && depth_valid(a, i)) {
    const float step = float(double(a.depth_weight) / count);
    const float d = a.inv_depth[i] - a.target_inv_depth[i];
    g = d > 0 ? step : (d < 0 ? -step : 0.f);
  }
  a.grad_inv_depth[i] = g;
}

// After the SSIM backward, whose blur spreads each pixel's partials over its neighbours.
__global__ void mask_grads_kernel(LossLaunch a) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const size_t n = size_t(a.width) * a.height;
  if (i >= n || a.pixel_mask[i]) return;
  a.grad_rgb[3 * i] = a.grad_rgb[3 * i + 1] = a.grad_rgb[3 * i + 2] = 0.f;
  if (a.grad_inv_depth) a.grad_inv_depth[i] = 0.f;
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("CUDA mapping loss: ", what, ": ", cudaGetErrorString(e));
}

}  // namespace

void ssim_window(float* w11) {
  double sum = 0, v[2 * kR + 1];
  for (int i = -kR; i <= kR; ++i) sum += v[i + kR] = std::exp(-0.5 * i * i / (1.5 * 1.5));
  for (int i = 0; i <= 2 * kR; ++i) w11[i] = float(v[i] / sum);
}

struct LossReadback {
  double* host = nullptr;  // pinned, 4 doubles
  cudaEvent_t copied = nullptr;
};

LossReadback* loss_readback_create() {
  auto* rb = new LossReadback;
  cudaError_t e = cudaMallocHost(&rb->host, 4 * sizeof(double));
  if (e == cudaSuccess) e = cudaEventCreateWithFlags(&rb->copied, cudaEventDisableTiming);
  if (e != cudaSuccess) {
    loss_readback_destroy(rb);
    check(e, "pinned loss sums");
  }
  return rb;
}

void loss_readback_destroy(LossReadback* rb) {
  if (!rb) return;
  if (rb->copied) {
    cudaEventSynchronize(rb->copied);
    cudaEventDestroy(rb->copied);
  }
  if (rb->host) cudaFreeHost(rb->host);
  delete rb;
}

void loss_readback_wait(LossReadback* rb, double* sums) {
  check(cudaEventSynchronize(rb->copied), "loss");
  for (int i = 0; i < 4; ++i) sums[i] = rb->host[i];
}

void launch_mapping_loss(const LossLaunch& a, LossReadback* rb) {
  Window win;
  ssim_window(win.w);
  check(cudaMemsetAsync(a.partials, 0, 4 * kLossSpread * sizeof(double)), "memset");
  const dim3 grid((a.width + kT - 1) / kT, (a.height + kT - 1) / kT, 3);
  ssim_forward_kernel<<<grid, 256>>>(a, win);
  check(cudaGetLastError(), "SSIM forward launch");
  if (a.want_grads && a.ssim_weight > 0.f) {
    ssim_backward_kernel<<<grid, 256>>>(a, win);
    check(cudaGetLastError(), "SSIM backward launch");
  }
  const size_t n = size_t(a.width) * a.height;
  const unsigned blocks = unsigned((n + 255) / 256);
  if (a.depth_weight > 0.f) {
    depth_sum_kernel<<<blocks, 256>>>(a);
    check(cudaGetLastError(), "depth launch");
  }
  finish_sums_kernel<<<1, 32>>>(a.partials, a.sums);  // the depth gradient reads the valid pixel count
  check(cudaGetLastError(), "sums launch");
  if (a.depth_weight > 0.f && a.want_grads) {
    depth_grad_kernel<<<blocks, 256>>>(a);
    check(cudaGetLastError(), "depth gradient launch");
  }
  if (a.want_grads && a.pixel_mask) {
    mask_grads_kernel<<<blocks, 256>>>(a);
    check(cudaGetLastError(), "gradient mask launch");
  }
  check(cudaMemcpyAsync(rb->host, a.sums, 4 * sizeof(double), cudaMemcpyDeviceToHost, 0), "loss sums copy");
  check(cudaEventRecord(rb->copied, 0), "loss sums event");
}

}  // namespace chungs::cuda::detail
