// Internal interface between the rasterizer's .cu files: launch functions and the per-splat data
// the forward writes and the compositing reads. CUDA-only header.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "chungs/render/cuda/rasterizer.hpp"
#include "chungs/render/raster_config.hpp"
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

struct ForwardImages {
  float *rgb, *depth, *inv_depth, *alpha;
  uint32_t *top_id, *last;
};

// order: the tiles in the order their blocks are launched (a permutation of 0 .. tiles - 1).
void composite_forward(const uint2* ranges, const uint32_t* order, const uint32_t* list, SplatData s,
                       const uint32_t* ids, int width, int height, const RasterConsts& k, ForwardImages out,
                       cudaStream_t stream);

void composite_backward(const uint2* ranges, const uint32_t* order, const uint32_t* list, SplatData s, int width,
                        int height,
                        const RasterConsts& k, const float* rgb, const float* depth, const float* inv_depth,
                        const float* alpha, const uint32_t* last, const DeviceRenderGrads& dl,
                        float* splat_grads, cudaStream_t stream);

void gaussian_backward(const GaussianArrays<float>& g, const uint32_t* ids, size_t n,
                       const RenderCamera<float>& cam, const RasterConsts& k, const uint8_t* visible,
                       const float* splat_grads, const DeviceGaussianGrads& out, cudaStream_t stream);

}  // namespace chungs::cuda::detail
