// Crowded tiles cut into segments (kernels.cuh, TileSegments): the work items of the compositing, and the
// pass that adds a split tile's segments up into the images. On a street mapped ten times denser than the
// sampler's default (bench_step_loop --visible 1000000), the most crowded tile held 14,017 entries
// against a mean of ~620: its one block walked them while the other SMs had run out of tiles.
#include <cub/device/device_scan.cuh>

#include "chungs/render/cuda/kernels.cuh"
#include "chungs/render/render_output.hpp"

namespace chungs::cuda::detail {

namespace {

__global__ void segment_count_kernel(const uint2* __restrict__ ranges, const uint32_t* __restrict__ order,
                                     uint32_t ntiles, uint32_t segment, uint32_t* __restrict__ nseg) {
  const uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= ntiles) return;
  const uint2 range = ranges[order[r]];
  const uint32_t entries = range.y - range.x;
  nseg[r] = segment > 0 && entries > segment ? (entries - 1) / segment + 1 : 1u;
}

// Tiles come most entries first, so the split ones (more than one segment) lead the items.
__global__ void segment_items_kernel(const uint32_t* __restrict__ order, const uint32_t* __restrict__ nseg,
                                     const uint32_t* __restrict__ first, uint32_t ntiles,
                                     uint4* __restrict__ items, uint32_t* __restrict__ counts) {
  const uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= ntiles) return;
  const uint32_t n = nseg[r], f = first[r], tile = order[r];
  for (uint32_t k = 0; k < n; ++k) items[f + k] = make_uint4(tile, k, n, 0);
  if (r + 1 == ntiles) counts[0] = f + n;
  const bool split = n > 1, next_split = r + 1 < ntiles && nseg[r + 1] > 1;
  if (split && !next_split) counts[1] = f + n;
  if (r == 0 && !split) counts[1] = 0;
}

// One block per split tile (its first item), a thread per pixel as in the forward: the segments' sums in
// depth order; the transmittance is that of the first segment that stopped the pixel (the ones after it
// start below min_T and add nothing), else of the last.
__global__ void __launch_bounds__(kBlock) merge_kernel(TileSegments ts, const uint32_t* __restrict__ ids,
                                                       int W, int H, RasterConsts k, ForwardImages out) {
  const uint32_t ib = blockIdx.x;
  if (ib >= ts.counts[1]) return;
  const uint4 item = ts.items[ib];
  if (item.y != 0) return;
  const int tiles_x = (W + kTileSize - 1) / kTileSize;
  const int tile = int(item.x);
  int lx, ly;
  pixel_of_thread(threadIdx.x, lx, ly);
  const int x = (tile % tiles_x) * kTileSize + lx, y = (tile / tiles_x) * kTileSize + ly;
  if (x >= W || y >= H) return;
  float acc[5] = {0, 0, 0, 0, 0}, best_w = 0.f, T = 1.f;
  int best = -1;
  uint32_t cnt = 0;
  bool stopped = false;
  for (uint32_t i = 0; i < item.z; ++i) {
    const float* v = ts.seg + size_t(ib + i) * kSegmentValues * kBlock + threadIdx.x;
#pragma unroll
    for (int c = 0; c < 5; ++c) acc[c] += v[(seg_acc + c) * kBlock];
    const float w = v[seg_best_w * kBlock];
    if (w > best_w) best_w = w, best = __float_as_int(v[seg_best * kBlock]);
    const uint32_t n = __float_as_uint(v[seg_count * kBlock]);
    if (n > 0) cnt = n;
    if (!stopped) T = v[seg_T * kBlock], stopped = v[seg_done * kBlock] != 0.f;
  }
  write_pixel(out, size_t(y) * W + x, acc, T, best, cnt, ids, k.bg);
}

unsigned blocks_for(size_t n, unsigned threads) { return unsigned((n + threads - 1) / threads); }

}  // namespace

size_t tile_segments_scratch_bytes(uint32_t ntiles) {
  size_t bytes = 0;
  cub::DeviceScan::ExclusiveSum(nullptr, bytes, static_cast<const uint32_t*>(nullptr),
                                static_cast<uint32_t*>(nullptr), int(ntiles));
  return bytes;
}

void build_tile_segments(const uint2* ranges, uint32_t ntiles, uint32_t segment, const uint32_t* tile_order,
                         uint32_t* nseg, uint32_t* first, uint4* items, uint32_t* counts, void* scratch,
                         size_t scratch_bytes, cudaStream_t stream) {
  segment_count_kernel<<<blocks_for(ntiles, 256), 256, 0, stream>>>(ranges, tile_order, ntiles, segment,
                                                                    nseg);
  cub::DeviceScan::ExclusiveSum(scratch, scratch_bytes, nseg, first, int(ntiles), stream);
  segment_items_kernel<<<blocks_for(ntiles, 256), 256, 0, stream>>>(tile_order, nseg, first, ntiles, items,
                                                                    counts);
}

void merge_tile_segments(const TileSegments& t, const uint32_t* ids, int width, int height,
                         const RasterConsts& k, ForwardImages out, cudaStream_t stream) {
  merge_kernel<<<t.split_grid, kBlock, 0, stream>>>(t, ids, width, height, k, out);
}

}  // namespace chungs::cuda::detail
