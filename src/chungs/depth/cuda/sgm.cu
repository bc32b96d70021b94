#include <cuda_runtime.h>

#include <mutex>

#include "chungs/common/error.hpp"
#include "chungs/depth/cuda/sgm_cuda.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda {

namespace {

constexpr unsigned kFull = 0xffffffffu;
constexpr int kBig = 1 << 20;  // a padded lane's cost: never a minimum, no overflow with penalties

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("stereo matching on the GPU: ", what, ": ", cudaGetErrorString(e));
}

__global__ void census_kernel(const uint8_t* __restrict__ img, int w, int h, uint64_t* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= w || y >= h) return;
  const uint8_t c = img[y * w + x];
  uint64_t bits = 0;
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -4; dx <= 4; ++dx) {
      if (dx == 0 && dy == 0) continue;
      const int xx = x + dx, yy = y + dy;
      const bool darker = xx >= 0 && xx < w && yy >= 0 && yy < h && img[yy * w + xx] < c;
      bits = (bits << 1) | uint64_t(darker);
    }
  out[size_t(y) * w + x] = bits;
}

// One warp walks one scanline (a row for dx != 0, a column for dy != 0); lane l holds disparities
// l*K .. l*K+K-1, so a disparity's neighbours sit in the same lane or the next one.
template <int K>
__global__ void path_kernel(const uint64_t* __restrict__ cl, const uint64_t* __restrict__ cr, int w, int h, int D,
                            int p1, int p2, int dx, int dy, bool first, uint16_t* __restrict__ sum) {
  const int line = (blockIdx.x * blockDim.x + threadIdx.x) / 32, lane = threadIdx.x & 31;
  const bool rows = dy == 0;
  const int lines = rows ? h : w, len = rows ? w : h;
  if (line >= lines) return;  // whole warps leave together: lines are per warp
  const bool forward = (rows ? dx : dy) > 0;
  int L[K];
  for (int i = 0; i < len; ++i) {
    const int s = forward ? i : len - 1 - i;
    const int x = rows ? s : line, y = rows ? line : s;
    const uint64_t a = cl[size_t(y) * w + x];
    int cost[K];
#pragma unroll
    for (int k = 0; k < K; ++k) {
      const int d = lane * K + k;
      cost[k] = d >= D ? kBig : x - d >= 0 ? __popcll(a ^ cr[size_t(y) * w + x - d]) : kSgmOutsideCost;
    }
    if (i == 0) {
#pragma unroll
      for (int k = 0; k < K; ++k) L[k] = cost[k];
    } else {
      int lm = kBig;
#pragma unroll
      for (int k = 0; k < K; ++k) lm = min(lm, L[k]);
      const int m = int(__reduce_min_sync(kFull, unsigned(lm)));
      int below = __shfl_up_sync(kFull, L[K - 1], 1), above = __shfl_down_sync(kFull, L[0], 1);
      if (lane == 0) below = kBig;
      if (lane == 31) above = kBig;
      int next[K];
#pragma unroll
      for (int k = 0; k < K; ++k) {
        const int d = lane * K + k;
        const int dm1 = k > 0 ? L[k - 1] : below, dp1 = k + 1 < K ? L[k + 1] : above;
        const int v = min(min(L[k], m + p2), min(dm1, dp1) + p1);
        next[k] = d >= D ? kBig : cost[k] + v - m;
      }
#pragma unroll
      for (int k = 0; k < K; ++k) L[k] = next[k];
    }
    uint16_t* out = sum + (size_t(y) * w + x) * D;
#pragma unroll
    for (int k = 0; k < K; ++k) {
      const int d = lane * K + k;
      if (d < D) out[d] = uint16_t(first ? L[k] : out[d] + L[k]);
    }
  }
}

// One warp per left pixel: the lowest-cost disparity (lowest d on ties), the uniqueness test against
// every candidate outside +-1, the sub-pixel parabola.
template <int K>
__global__ void winner_kernel(const uint16_t* __restrict__ sum, size_t pixels, int D, int uniqueness,
                              int16_t* __restrict__ left) {
  const size_t p = (size_t(blockIdx.x) * blockDim.x + threadIdx.x) / 32;
  const int lane = threadIdx.x & 31;
  if (p >= pixels) return;
  const uint16_t* s = sum + p * D;
  int v[K], lb = kBig, ld = 1 << 30;
#pragma unroll
  for (int k = 0; k < K; ++k) {
    const int d = lane * K + k;
    v[k] = d < D ? s[d] : kBig;
    if (v[k] < lb) lb = v[k], ld = d;
  }
  const int m = int(__reduce_min_sync(kFull, unsigned(lb)));
  const int best = int(__reduce_min_sync(kFull, unsigned(lb == m ? ld : 1 << 30)));
  int lo = kBig;
#pragma unroll
  for (int k = 0; k < K; ++k) {
    const int d = lane * K + k;
    if (d < best - 1 || d > best + 1) lo = min(lo, v[k]);
  }
  const int other = int(__reduce_min_sync(kFull, unsigned(lo)));
  if (lane != 0) return;
  int out = kNoDisparity;
  if (!((long long)other * 100 <= (long long)m * (100 + uniqueness))) {
    out = best * 16;
    if (best > 0 && best + 1 < D) out += sgm_subpixel_offset(s[best - 1], m, s[best + 1]);
  }
  left[p] = int16_t(out);
}

__global__ void right_kernel(const uint16_t* __restrict__ sum, int w, int h, int D, int16_t* __restrict__ right) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y;
  if (x >= w || y >= h) return;
  int best = 0, best_cost = 1 << 30;
  for (int d = 0; d < D && x + d < w; ++d) {
    const int c = sum[(size_t(y) * w + x + d) * D + d];
    if (c < best_cost) best_cost = c, best = d;
  }
  right[size_t(y) * w + x] = int16_t(best * 16);
}

template <int K>
void launch_paths_and_winners(const uint64_t* cl, const uint64_t* cr, int w, int h, const SgmParams& p,
                              uint16_t* sum, int16_t* left, int16_t* right, cudaStream_t stream) {
  const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (int i = 0; i < 4; ++i) {
    const int lines = dirs[i][1] == 0 ? h : w;
    path_kernel<K><<<(lines + 3) / 4, 128, 0, stream>>>(cl, cr, w, h, p.disparities, p.p1, p.p2, dirs[i][0],
                                                         dirs[i][1], i == 0, sum);
    check(cudaGetLastError(), "aggregating costs");
  }
  const size_t pixels = size_t(w) * size_t(h);
  winner_kernel<K><<<unsigned((pixels + 7) / 8), 256, 0, stream>>>(sum, pixels, p.disparities, p.uniqueness, left);
  check(cudaGetLastError(), "picking disparities");
  right_kernel<<<dim3((w + 127) / 128, h), 128, 0, stream>>>(sum, w, h, p.disparities, right);
  check(cudaGetLastError(), "picking right-view disparities");
}

// One workspace for the process: keyframe loads run on several threads but the device matches one
// pair in a few milliseconds, so they take turns instead of each holding ~125 MB of VRAM.
struct Workspace {
  std::mutex mutex;
  cudaStream_t stream = nullptr;
  DeviceBytes images, census, sum, out;
};

Workspace& workspace() {
  // Never destroyed: the CUDA runtime may be gone before static destructors run.
  static Workspace* ws = new Workspace;
  return *ws;
}

}  // namespace

SgmDisparities sgm_disparities(const Image8& left, const Image8& right, const SgmParams& params) {
  check_sgm_inputs(left, right, params);
  const int w = left.width(), h = left.height();
  const size_t px = size_t(w) * size_t(h);
  Workspace& ws = workspace();
  std::lock_guard lock(ws.mutex);
  if (!ws.stream) check(cudaStreamCreateWithFlags(&ws.stream, cudaStreamNonBlocking), "creating a stream");
  ws.images.reserve(2 * px);
  ws.census.reserve(2 * px * sizeof(uint64_t));
  ws.sum.reserve(px * size_t(params.disparities) * sizeof(uint16_t));
  ws.out.reserve(2 * px * sizeof(int16_t));
  auto* img = static_cast<uint8_t*>(ws.images.data());
  auto* census = static_cast<uint64_t*>(ws.census.data());
  auto* out = static_cast<int16_t*>(ws.out.data());
  check(cudaMemcpyAsync(img, left.data(), px, cudaMemcpyHostToDevice, ws.stream), "uploading the left image");
  check(cudaMemcpyAsync(img + px, right.data(), px, cudaMemcpyHostToDevice, ws.stream), "uploading the right image");
  const dim3 block(32, 8), grid((w + 31) / 32, (h + 7) / 8);
  census_kernel<<<grid, block, 0, ws.stream>>>(img, w, h, census);
  census_kernel<<<grid, block, 0, ws.stream>>>(img + px, w, h, census + px);
  check(cudaGetLastError(), "census transform");
  auto* sum = static_cast<uint16_t*>(ws.sum.data());
  switch ((params.disparities + 31) / 32) {
#define CHUNGS_SGM_CASE(k) \
  case k: launch_paths_and_winners<k>(census, census + px, w, h, params, sum, out, out + px, ws.stream); break;
    CHUNGS_SGM_CASE(1) CHUNGS_SGM_CASE(2) CHUNGS_SGM_CASE(3) CHUNGS_SGM_CASE(4)
    CHUNGS_SGM_CASE(5) CHUNGS_SGM_CASE(6) CHUNGS_SGM_CASE(7) CHUNGS_SGM_CASE(8)
#undef CHUNGS_SGM_CASE
    default: fail("stereo matching: ", params.disparities, " disparities");
  }
  SgmDisparities r;
  r.width = w, r.height = h;
  r.left.resize(px);
  r.right.resize(px);
  check(cudaMemcpyAsync(r.left.data(), out, px * sizeof(int16_t), cudaMemcpyDeviceToHost, ws.stream), "downloading");
  check(cudaMemcpyAsync(r.right.data(), out + px, px * sizeof(int16_t), cudaMemcpyDeviceToHost, ws.stream),
        "downloading");
  check(cudaStreamSynchronize(ws.stream), "matching");
  return r;
}

}  // namespace chungs::cuda
