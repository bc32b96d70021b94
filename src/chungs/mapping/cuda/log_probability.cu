// LoG probability kernels. Each pass is one pixel per thread, reading its neighbours from global
// memory (the image is small and cached); every sum runs in the CPU twin's order with explicit
// round-to-nearest operations (no fused multiply-add), so the result matches it to the last bit.
#include <cuda_runtime.h>

#include "chungs/common/error.hpp"
#include "chungs/mapping/cuda/log_probability.hpp"

namespace chungs::cuda::detail {

namespace {

constexpr int kBX = 32, kBY = 8;

// One 3x3 mean with the edge pixel repeated: the row means first, then their mean, as box3 does.
__global__ void box3_kernel(const float* in, float* out, int w, int h, int ch) {
  const int x = blockIdx.x * kBX + threadIdx.x, y = blockIdx.y * kBY + threadIdx.y;
  if (x >= w || y >= h) return;
  const int xl = max(x - 1, 0), xr = min(x + 1, w - 1);
  const int rows[3] = {max(y - 1, 0), y, min(y + 1, h - 1)};
  for (int c = 0; c < ch; ++c) {
    float m[3];
#pragma unroll
    for (int k = 0; k < 3; ++k) {
      const float* r = in + size_t(rows[k]) * w * ch;
      m[k] = __fdiv_rn(__fadd_rn(__fadd_rn(r[xl * ch + c], r[x * ch + c]), r[xr * ch + c]), 3.f);
    }
    out[(size_t(y) * w + x) * ch + c] = __fdiv_rn(__fadd_rn(__fadd_rn(m[0], m[1]), m[2]), 3.f);
  }
}

// |4-neighbour Laplacian| summed over channels; zero on the 1-pixel border.
__global__ void laplacian_kernel(const float* b, float* lap, int w, int h, int ch) {
  const int x = blockIdx.x * kBX + threadIdx.x, y = blockIdx.y * kBY + threadIdx.y;
  if (x >= w || y >= h) return;
  float s = 0.f;
  if (x > 0 && y > 0 && x < w - 1 && y < h - 1) {
    const size_t p = (size_t(y) * w + x) * ch, row = size_t(w) * ch;
    for (int c = 0; c < ch; ++c) {
      const float sum4 = __fadd_rn(__fadd_rn(__fadd_rn(b[p - ch + c], b[p + ch + c]), b[p - row + c]), b[p + row + c]);
      s = __fadd_rn(s, __fsub_rn(sum4, __fmul_rn(4.f, b[p + c])));
    }
  }
  lap[size_t(y) * w + x] = fabsf(s);
}

// Mean over the radius-3.5 disc (outside pixels count as zero), clamped to [0, 1].
__global__ void disc_kernel(const float* lap, float* out, int w, int h, float inv) {
  const int x = blockIdx.x * kBX + threadIdx.x, y = blockIdx.y * kBY + threadIdx.y;
  if (x >= w || y >= h) return;
  float s = 0.f;
#pragma unroll
  for (int dy = -3; dy <= 3; ++dy)
#pragma unroll
    for (int dx = -3; dx <= 3; ++dx) {
      if (dx * dx + dy * dy > 12) continue;  // 12.25 on integers
      const int xx = x + dx, yy = y + dy;
      if (xx >= 0 && yy >= 0 && xx < w && yy < h) s = __fadd_rn(s, lap[size_t(yy) * w + xx]);
    }
  out[size_t(y) * w + x] = fminf(fmaxf(__fmul_rn(s, inv), 0.f), 1.f);
}

// In double, as sampling_probability on the host.
__global__ void penalty_kernel(float* p, const float* pr, const float* alpha, size_t n, double density,
                               double empty_floor) {
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  double v = double(pr ? __fsub_rn(p[i], pr[i]) : p[i]);
  v = __dmul_rn(density, fmax(v, 0.0));
  if (alpha && alpha[i] < 0.5f) v = fmax(v, empty_floor);
  p[i] = float(fmin(v, 1.0));
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("CUDA LoG probability: ", what, ": ", cudaGetErrorString(e));
}

}  // namespace

void launch_log_probability(const LogLaunch& a) {
  const dim3 block(kBX, kBY), grid((a.width + kBX - 1) / kBX, (a.height + kBY - 1) / kBY);
  box3_kernel<<<grid, block>>>(a.image, a.blur_a, a.width, a.height, a.channels);
  check(cudaGetLastError(), "first blur launch");
  box3_kernel<<<grid, block>>>(a.blur_a, a.blur_b, a.width, a.height, a.channels);
  check(cudaGetLastError(), "second blur launch");
  laplacian_kernel<<<grid, block>>>(a.blur_b, a.lap, a.width, a.height, a.channels);
  check(cudaGetLastError(), "Laplacian launch");
  disc_kernel<<<grid, block>>>(a.lap, a.out, a.width, a.height, a.inv_disc);
  check(cudaGetLastError(), "disc average launch");
}

void launch_penalty(float* p, const float* p_render, const float* alpha, size_t pixels, double density,
                    double empty_floor) {
  const unsigned blocks = unsigned((pixels + 255) / 256);
  penalty_kernel<<<blocks, 256>>>(p, p_render, alpha, pixels, density, empty_floor);
  check(cudaGetLastError(), "penalty launch");
}

}  // namespace chungs::cuda::detail
