// Internal interface between the rasterizer's .cu files: launch functions and the per-splat data
// the forward writes and the compositing reads. CUDA-only header.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "chungs/render/cuda/rasterizer.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_output.hpp"
#include "chungs/render/render_camera.hpp"

namespace chungs::cuda::detail {

constexpr int kBlock = kTileSize * kTileSize;  // one thread per pixel of a tile
constexpr int kSplatGrads = 10;  // d/d(mx, my, ca, cb, cc, opacity, r, g, b, z), as cpu::SplatGradIndex

// The configuration in the float arithmetic of the kernels.
struct RasterConsts {
  float near_plane, low_pass, alpha_max, min_T, extent_sigma, guard_band;
  float min_alpha, log_min_alpha;  // log only used when min_alpha > 0
  float bg[3];
  int sh_degree;
  bool antialias;  // opacity scaled by sqrt(det0 / det), as the CPU twin
};
RasterConsts make_consts(const RasterConfig& c);

// Projected splats, one entry per rendered index:
//   a = (mx, my, opacity, power_min), b = (ca, cb, cc, z), c = (r, g, b, 1/z).
struct SplatData {
  const float4* a;
  const float4* b;
  const float4* c;
};

// Pixel (x, y) of thread t in its tile: 8 warps of 8x4 pixels, so a small splat touches few warps.
__device__ __forceinline__ void pixel_of_thread(int t, int& lx, int& ly) {
  const int w = t >> 5, l = t & 31;
  lx = (w & 1) * 8 + (l & 7);
  ly = (w >> 1) * 4 + (l >> 3);
}

// Thread t of a forward block whose pixel is (lx, ly) in its tile (the inverse of pixel_of_thread).
__device__ __forceinline__ int thread_of_pixel(int lx, int ly) {
  return (((ly >> 2) << 1) + (lx >> 3)) * 32 + ((ly & 3) << 3) + (lx & 7);
}

struct ForwardImages {
  float *rgb, *depth, *inv_depth, *alpha;
  uint32_t *top_id, *last;
};

// Pixel p of the forward's images from its composited sums (r g b depth inv_depth), final transmittance,
// top splat (-1: none) and entries walked.
__device__ __forceinline__ void write_pixel(const ForwardImages& out, size_t p, const float* acc, float T, int best,
                                            uint32_t cnt, const uint32_t* ids, const float* bg) {
  out.rgb[3 * p] = acc[0] + T * bg[0];
  out.rgb[3 * p + 1] = acc[1] + T * bg[1];
  out.rgb[3 * p + 2] = acc[2] + T * bg[2];
  out.depth[p] = acc[3];
  out.inv_depth[p] = acc[4];
  out.alpha[p] = 1.f - T;
  out.top_id[p] = best < 0 ? kNoGaussian : ids[best];
  out.last[p] = cnt;
}

// A crowded tile is composited in segments: runs of `segment` consecutive entries (depth order), each by a
// block of its own, so that one tile's long list no longer holds up the whole image (tile_segments.cu).
// A segment starts from the transmittance its pixels have after the segments before it (their products,
// a first pass) and leaves partial sums that a last pass adds up in order. Item b (one block) is segment
// items[b].y of items[b].z of tile items[b].x; the items of split tiles come first, and their per-pixel
// values lie in `seg` at kSegmentValues x kBlock floats per item.
constexpr int kSegmentValues = 11;
enum SegmentValue { seg_product, seg_acc, seg_T = seg_acc + 5, seg_best_w, seg_best, seg_count, seg_done };
struct TileSegments {
  const uint4* items;
  const uint32_t* counts;  // [0] items, [1] items of split tiles
  uint32_t segment;        // entries a segment (0: a tile is one segment)
  uint32_t grid;           // blocks launched: at least counts[0]
  uint32_t split_grid;     // blocks of the passes over split tiles only: at least counts[1]
  float* seg;
};

// Orders the tiles' work (most entries first) and cuts tiles of more than `segment` entries into segments:
// fills items and counts; `nseg` and `first` hold a count per tile; `scratch` is the scan's room.
void build_tile_segments(const uint2* ranges, uint32_t ntiles, uint32_t segment, const uint32_t* tile_order,
                         uint32_t* nseg, uint32_t* first, uint4* items, uint32_t* counts, void* scratch,
                         size_t scratch_bytes, cudaStream_t stream);
size_t tile_segments_scratch_bytes(uint32_t ntiles);
// Adds up the split tiles' segments into the forward's images.
void merge_tile_segments(const TileSegments& t, const uint32_t* ids, int width, int height,
                         const RasterConsts& k, ForwardImages out, cudaStream_t stream);

void composite_forward(const uint2* ranges, const TileSegments& t, const uint32_t* list, SplatData s,
                       const uint32_t* ids, int width, int height, const RasterConsts& k, ForwardImages out,
                       cudaStream_t stream);

void composite_backward(const uint2* ranges, const TileSegments& t, const uint32_t* list, SplatData s,
                        int width, int height, const RasterConsts& k, const float* rgb, const float* depth,
                        const float* inv_depth, const float* alpha, const uint32_t* last,
                        const DeviceRenderGrads& dl, float* splat_grads, cudaStream_t stream);

void gaussian_backward(const GaussianArrays<float>& g, const uint32_t* ids, size_t n,
                       const RenderCamera<float>& cam, const RasterConsts& k, const uint8_t* visible,
                       const float* splat_grads, const DeviceGaussianGrads& out, cudaStream_t stream);

}  // namespace chungs::cuda::detail
