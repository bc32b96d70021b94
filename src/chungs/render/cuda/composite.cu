// Per-tile compositing, forward and backward (twin of cpu/composite_forward.cpp and
// cpu/composite_backward.cpp). One block per 16x16 tile (forward: 256 threads, one per pixel;
// backward: 128, two pixels each); the tile's splats are staged through shared memory in batches.
// Block b takes work item b: tiles ordered by their entries, most first, and a tile of more than
// RasterConfig::segment_entries cut into segments of its own blocks (TileSegments, tile_segments.cu). A
// KITTI view needs about two waves of blocks, and a crowded tile started in the second wave had left most
// SMs idle at the end (achieved occupancy 30 % of a theoretical 50 % in the backward); a tile of 19 k
// entries on a dense street took 1.7 ms of forward and 3 ms of backward in its one block. The
// Gaussian falloff uses the fast exponential (relative error ~1e-7 over the exponents that pass the alpha
// cut-off).
// Most splats are a few pixels wide, so a warp's 8x4 (backward 8x8) pixels lie outside most of its
// tile's splats: when a batch is staged, each splat gets a bit per warp whose pixels its ellipse's box
// (widened by a pixel against rounding) reaches, and a warp walks only the splats of its bits, in order.
// A splat skipped that way has no pixel of the warp with power >= its cut-off, so the images and
// gradients are those of walking every splat.
#include "chungs/render/cuda/kernels.cuh"
#include "chungs/render/render_output.hpp"

namespace chungs::cuda::detail {

namespace {

struct Batch {
  float4 a[kBlock], b[kBlock], c[kBlock];
  uint32_t j[kBlock];
  uint8_t warps[kBlock];  // bit w: the splat may reach a pixel of warp w
};

// Bits of the warps (rectangles of 8 x `rows` pixels: warp w at column 8 (w & 1), row rows (w >> 1))
// that the box of splat (a, b) reaches in the tile whose first pixel is (x0, y0). All bits when the
// box cannot be trusted (a degenerate conic).
template <int kWarps, int kRows>
__device__ __forceinline__ uint8_t warps_reached(float4 a, float4 b, int x0, int y0) {
  const float q = -2.f * a.w, dc = b.x * b.z - b.y * b.y;
  const float ex = sqrtf(q * b.z / dc), ey = sqrtf(q * b.x / dc);
  if (!(ex < 1e6f && ey < 1e6f)) return uint8_t((1u << kWarps) - 1);  // NaN or huge: no culling
  const float mx = a.x - float(x0), my = a.y - float(y0);
  const float rx = ex * 1.001f + 1.f, ry = ey * 1.001f + 1.f;
  uint32_t bits = 0;
#pragma unroll
  for (int w = 0; w < kWarps; ++w) {
    const float c0 = float(8 * (w & 1)), r0 = float(kRows * (w >> 1));
    if (mx + rx >= c0 && mx - rx <= c0 + 7.f && my + ry >= r0 && my - ry <= r0 + float(kRows - 1))
      bits |= 1u << w;
  }
  return uint8_t(bits);
}

template <int kWarps, int kRows>
__device__ __forceinline__ void load_batch(Batch& sm, const uint32_t* list, SplatData s, uint32_t begin,
                                           uint32_t end, int x0, int y0) {
  const uint32_t e = begin + threadIdx.x;
  if (e < end) {
    const uint32_t j = list[e];
    const float4 a = s.a[j], b = s.b[j];
    sm.j[threadIdx.x] = j;
    sm.a[threadIdx.x] = a;
    sm.b[threadIdx.x] = b;
    sm.c[threadIdx.x] = s.c[j];
    sm.warps[threadIdx.x] = warps_reached<kWarps, kRows>(a, b, x0, y0);
  }
}

// The splats among batch entries [g, g + 32) (of m) that reach warp `warp`, one bit each.
__device__ __forceinline__ uint32_t reaching(const Batch& sm, int g, int m, int warp, int lane) {
  return __ballot_sync(0xffffffffu, g + lane < m && ((sm.warps[g + lane] >> warp) & 1));
}

// One segment of a tile (the whole tile when it is not split). kProduct: the first pass over a split tile's
// segments but its last, which only multiplies its pixels' (1 - alpha) until they stop; otherwise the
// composite itself, from the transmittance the segments before it left, into the images (a tile of one
// segment) or into the segment's partial sums.
template <bool kProduct>
__global__ void __launch_bounds__(kBlock)
    forward_kernel(const uint2* __restrict__ ranges, TileSegments ts, const uint32_t* __restrict__ list,
                   SplatData s, const uint32_t* __restrict__ ids, int W, int H, RasterConsts k,
                   ForwardImages out) {
  __shared__ Batch sm;
  const uint32_t ib = blockIdx.x;
  if (ib >= ts.counts[kProduct ? 1 : 0]) return;
  const uint4 item = ts.items[ib];
  const uint32_t seg = item.y, nseg = item.z;
  if (kProduct && seg + 1 >= nseg) return;  // the last segment's product is nobody's start
  const int tiles_x = (W + kTileSize - 1) / kTileSize;
  const int tile = int(item.x);
  int lx, ly;
  pixel_of_thread(threadIdx.x, lx, ly);
  const int x0 = (tile % tiles_x) * kTileSize, y0 = (tile / tiles_x) * kTileSize;  // the tile's first pixel
  const int x = x0 + lx, y = y0 + ly;
  const bool inside = x < W && y < H;
  const float fx = float(x), fy = float(y);
  const uint2 range = ranges[tile];
  const uint32_t begin = range.x + seg * ts.segment;
  const uint32_t end = nseg == 1 ? range.y : min(range.y, begin + ts.segment);

  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;

  float T = 1.f, acc[5] = {0, 0, 0, 0, 0}, best_w = 0.f;
  if constexpr (!kProduct)
    for (uint32_t i = 0; i < seg; ++i)
      T *= ts.seg[(size_t(ib - seg + i) * kSegmentValues + seg_product) * kBlock + threadIdx.x];
  int best = -1;
  uint32_t cnt = 0;
  // Below min_T at the start: a segment before this one stopped the pixel.
  bool done = !inside || T < k.min_T;
  for (uint32_t base = begin; base < end; base += kBlock) {
    if (__syncthreads_count(done) == kBlock) break;
    load_batch<8, 4>(sm, list, s, base, end, x0, y0);
    __syncthreads();
    const int m = min(kBlock, int(end - base));
    for (int g0 = 0; g0 < m; g0 += 32) {
      if (__all_sync(0xffffffffu, done)) break;
      for (uint32_t bits = reaching(sm, g0, m, warp, lane); bits; bits &= bits - 1) {
        if (done) continue;
        const int i = g0 + __ffs(bits) - 1;
        const float4 a = sm.a[i], b = sm.b[i];
        const float dx = fx - a.x, dy = fy - a.y;
        const float power = -0.5f * (b.x * dx * dx + b.z * dy * dy) - (b.y * dy) * dx;
        if (!(power >= a.w)) continue;
        const float alpha = fminf(k.alpha_max, a.z * __expf(power));
        const float nT = T * (1.f - alpha);
        if constexpr (kProduct) {
          // The stopping splat is in the product: the segments after it start below min_T.
          T = nT;
          done = nT < k.min_T;
        } else {
          if (nT < k.min_T) {
            done = true;
            continue;
          }
          const float w = alpha * T;
          const float4 c = sm.c[i];
          acc[0] += w * c.x, acc[1] += w * c.y, acc[2] += w * c.z, acc[3] += w * b.w, acc[4] += w * c.w;
          T = nT;
          if (w > best_w) best_w = w, best = int(sm.j[i]);
          cnt = base - range.x + i + 1;
        }
      }
    }
  }
  if (kProduct || nseg > 1) {
    float* const mine = ts.seg + size_t(ib) * kSegmentValues * kBlock + threadIdx.x;
    if constexpr (kProduct) {
      mine[seg_product * kBlock] = T;
    } else {
#pragma unroll
      for (int c = 0; c < 5; ++c) mine[(seg_acc + c) * kBlock] = acc[c];
      mine[seg_T * kBlock] = T;
      mine[seg_best_w * kBlock] = best_w;
      mine[seg_best * kBlock] = __int_as_float(best);
      mine[seg_count * kBlock] = __uint_as_float(cnt);
      mine[seg_done * kBlock] = done && inside ? 1.f : 0.f;
    }
    return;
  }
  if (inside) write_pixel(out, size_t(y) * W + x, acc, T, best, cnt, ids, k.bg);
}

// Sums N values over the warp in log2(32) shuffle rounds that each halve the values a lane holds
// (lanes with the round's bit set keep the upper half and send the lower), so 10 values cost 12
// shuffles instead of 50. Afterwards lane l holds the full sum of the value reduced_index(l) names.
template <int N>
__device__ __forceinline__ void fold(float* v, int lane, int bit) {
  constexpr int Hh = (N + 1) / 2;
  const bool upper = (lane & bit) != 0;
#pragma unroll
  for (int i = 0; i < Hh; ++i) {
    const float lo = v[i], hi = (i + Hh < N) ? v[i + Hh] : 0.f;
    const float send = upper ? lo : hi;
    v[i] = (upper ? hi : lo) + __shfl_xor_sync(0xffffffffu, send, bit);
  }
}

// The value index lane `lane` ends with after the folds 10 -> 5 -> 3 -> 2 -> 1 (bits 16, 8, 4, 2),
// or -1 for a padding slot. Lanes l and l ^ 1 hold the same value.
__device__ __forceinline__ int reduced_index(int lane) {
  int idx = 0, real = kSplatGrads;
  const int sizes[4] = {kSplatGrads, 5, 3, 2};
#pragma unroll
  for (int r = 0; r < 4; ++r) {
    const int Hh = (sizes[r] + 1) / 2;
    if (lane & (16 >> r)) {
      idx += Hh;
      real = max(real - Hh, 0);
    } else {
      real = min(real, Hh);
    }
  }
  return real > 0 ? idx : -1;
}

// P pixels per thread (rows 4 apart), 256 / P threads: each (warp, splat) step loads the splat and
// reduces its gradient once for 32 P pixels.
template <int P>
__global__ void __launch_bounds__(kBlock / P)
    backward_kernel(const uint2* __restrict__ ranges, TileSegments ts, const uint32_t* __restrict__ list,
                    SplatData s, int W, int H, RasterConsts k, const float* __restrict__ rgb,
                    const float* __restrict__ depth, const float* __restrict__ inv_depth,
                    const float* __restrict__ alpha_img, const uint32_t* __restrict__ last,
                    DeviceRenderGrads dl, float* __restrict__ splat_grads) {
  constexpr int kThreads = kBlock / P;
  __shared__ Batch sm;
  __shared__ uint32_t max_stop;
  const uint32_t ib = blockIdx.x;
  if (ib >= ts.counts[0]) return;
  const uint4 item = ts.items[ib];
  const uint32_t seg = item.y, nseg = item.z;
  const int tiles_x = (W + kTileSize - 1) / kTileSize;
  const int tile = int(item.x);
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  const int lx = (warp & 1) * 8 + (lane & 7), ly0 = (warp >> 1) * 4 * P + (lane >> 3);
  const int x0 = (tile % tiles_x) * kTileSize, y0 = (tile / tiles_x) * kTileSize;  // the tile's first pixel
  const int x = x0 + lx;
  const float fx = float(x);
  const int my_index = reduced_index(lane);
  const bool writer = (lane & 1) == 0 && my_index >= 0;

  // Per pixel: transmittance, dL/d(final) of r g b depth inv_depth, and one running sum that stands in
  // for the five channels' remainders: with C_c the final value of channel c and C_c,i the part
  // composited up to and including splat i, dL/dalpha_i = T_i sum_c g_c f_c - Q_i / (1 - alpha_i), where
  // Q_i = sum_c g_c (C_c - C_c,i) - T_final dL/dalpha. Q starts at sum_c g_c C_c - T_final dL/dalpha and
  // loses w_i sum_c g_c f_c at each splat, so a pixel carries one float where it had carried ten.
  float fy[P], T[P], Q[P], g[P][5];
  uint32_t stop[P], my_stop = 0;
#pragma unroll
  for (int q = 0; q < P; ++q) {
    const int y = y0 + ly0 + 4 * q;
    fy[q] = float(y);
    T[q] = 1.f, Q[q] = 0.f, stop[q] = 0;
#pragma unroll
    for (int c = 0; c < 5; ++c) g[q][c] = 0.f;
    if (x < W && y < H) {
      const size_t p = size_t(y) * W + x;
      float fin[5];
#pragma unroll
      for (int c = 0; c < 3; ++c) {
        fin[c] = rgb[3 * p + c];
        g[q][c] = dl.rgb ? dl.rgb[3 * p + c] : 0.f;
      }
      fin[3] = depth[p], fin[4] = inv_depth[p];
      g[q][3] = dl.depth ? dl.depth[p] : 0.f;
      g[q][4] = dl.inv_depth ? dl.inv_depth[p] : 0.f;
      Q[q] = -(dl.alpha ? dl.alpha[p] * (1.f - alpha_img[p]) : 0.f);
#pragma unroll
      for (int c = 0; c < 5; ++c) Q[q] += g[q][c] * fin[c];
      stop[q] = last[p];
      my_stop = max(my_stop, stop[q]);
    }
  }
  if (threadIdx.x == 0) max_stop = 0;
  __syncthreads();
  if (my_stop > 0) atomicMax(&max_stop, my_stop);
  __syncthreads();
  const uint2 range = ranges[tile];
  const uint32_t begin = range.x + seg * ts.segment;
  const uint32_t end = min(range.x + max_stop, nseg == 1 ? range.y : min(range.y, begin + ts.segment));
  if (begin >= end) return;  // block-uniform: no pixel walked this far
  if (seg > 0) {
    // A later segment of a split tile starts where the forward's segments before it left its pixels:
    // T is their products, and Q has lost what they composited (sum_c g_c C_c of each).
#pragma unroll
    for (int q = 0; q < P; ++q) {
      const float* v = ts.seg + thread_of_pixel(lx, ly0 + 4 * q);
      for (uint32_t i = 0; i < seg; ++i) {
        const float* before = v + size_t(ib - seg + i) * kSegmentValues * kBlock;
        T[q] *= before[seg_product * kBlock];
#pragma unroll
        for (int c = 0; c < 5; ++c) Q[q] -= g[q][c] * before[(seg_acc + c) * kBlock];
      }
    }
  }
  // Entries past the last one any pixel of this warp walked need no work from the warp.
  uint32_t warp_stop = my_stop;
#pragma unroll
  for (int o = 16; o > 0; o >>= 1) warp_stop = max(warp_stop, __shfl_xor_sync(0xffffffffu, warp_stop, o));
  const uint32_t warp_end = min(end, range.x + warp_stop);

  for (uint32_t base = begin; base < end; base += kThreads) {
    __syncthreads();  // the previous batch is consumed
    load_batch<kThreads / 32, 4 * P>(sm, list, s, base, end, x0, y0);
    __syncthreads();
    const int m = min(kThreads, int(warp_end) - int(base));
    for (int g0 = 0; g0 < m; g0 += 32) {
      for (uint32_t bits = reaching(sm, g0, m, warp, lane); bits; bits &= bits - 1) {
        const int i = g0 + __ffs(bits) - 1;
        const float4 a = sm.a[i], b = sm.b[i];
        const uint32_t entry = base - range.x + i;
        const float dx = fx - a.x;
        float dy[P], power[P];
        bool live[P], any_live = false;
#pragma unroll
        for (int q = 0; q < P; ++q) {
          dy[q] = fy[q] - a.y;
          power[q] = -0.5f * (b.x * dx * dx + b.z * dy[q] * dy[q]) - (b.y * dy[q]) * dx;
          live[q] = power[q] >= a.w && entry < stop[q];
          any_live |= live[q];
        }
        if (!__any_sync(0xffffffffu, any_live)) continue;
        float v[kSplatGrads] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
        const float4 c = sm.c[i];
        const float dz_inv = c.w * c.w;
#pragma unroll
        for (int q = 0; q < P; ++q) {
          if (!live[q]) continue;
          const float G = __expf(power[q]);
          const float raw = a.z * G;
          const bool clamped = raw > k.alpha_max;
          const float alpha = clamped ? k.alpha_max : raw;
          const float w = alpha * T[q];
          // alpha <= alpha_max < 1, so 1 - alpha is far from zero and the fast reciprocal is exact enough.
          const float inv_1ma = __fdividef(1.f, 1.f - alpha);
          const float gf = g[q][0] * c.x + g[q][1] * c.y + g[q][2] * c.z + g[q][3] * b.w + g[q][4] * c.w;
          Q[q] -= w * gf;
          const float dalpha = T[q] * gf - Q[q] * inv_1ma;
          T[q] *= 1.f - alpha;
          const float dal = clamped ? 0.f : dalpha;
          const float gpow = dal * alpha;
          v[0] += gpow * (b.x * dx + b.y * dy[q]);
          v[1] += gpow * (b.y * dx + b.z * dy[q]);
          v[2] += gpow * (-0.5f * dx * dx);
          v[3] -= gpow * (dx * dy[q]);
          v[4] += gpow * (-0.5f * dy[q] * dy[q]);
          v[5] += dal * G;
          v[6] += w * g[q][0], v[7] += w * g[q][1], v[8] += w * g[q][2];
          v[9] += w * (g[q][3] - g[q][4] * dz_inv);
        }
        fold<10>(v, lane, 16);
        fold<5>(v, lane, 8);
        fold<3>(v, lane, 4);
        fold<2>(v, lane, 2);
        v[0] += __shfl_xor_sync(0xffffffffu, v[0], 1);
        if (writer) atomicAdd(splat_grads + size_t(sm.j[i]) * kSplatGrads + my_index, v[0]);
      }
    }
  }
}

}  // namespace

void composite_forward(const uint2* ranges, const TileSegments& t, const uint32_t* list, SplatData s,
                       const uint32_t* ids, int width, int height, const RasterConsts& k, ForwardImages out,
                       cudaStream_t stream) {
  if (t.split_grid > 0)  // the split tiles' segment products (blocks past the split items return at once)
    forward_kernel<true><<<t.split_grid, kBlock, 0, stream>>>(ranges, t, list, s, ids, width, height, k, out);
  forward_kernel<false><<<t.grid, kBlock, 0, stream>>>(ranges, t, list, s, ids, width, height, k, out);
  if (t.split_grid > 0) merge_tile_segments(t, ids, width, height, k, out, stream);
}

void composite_backward(const uint2* ranges, const TileSegments& t, const uint32_t* list, SplatData s,
                        int width, int height, const RasterConsts& k, const float* rgb, const float* depth,
                        const float* inv_depth, const float* alpha, const uint32_t* last,
                        const DeviceRenderGrads& dl, float* splat_grads, cudaStream_t stream) {
  // 2 pixels per thread measured 1-3 % faster forward + backward than 1 on every benchmark case, and
  // steadier than 4 (H100, bench/README.md).
  constexpr int kPixels = 2;
  backward_kernel<kPixels><<<t.grid, kBlock / kPixels, 0, stream>>>(
      ranges, t, list, s, width, height, k, rgb, depth, inv_depth, alpha, last, dl, splat_grads);
}

}  // namespace chungs::cuda::detail
