// The CUDA rasterizer: the same function as CpuRasterizer<float> (its CPU twin, the reference of the
// parity tests) over Gaussians in device memory, addressed by a device list of pool slots.
// Forward: per-Gaussian projection + SH colour, a depth sort of the Gaussians, one (tile, Gaussian)
// entry per touched tile emitted in depth order and stably sorted by tile (CUB radix sort), then
// one 16x16 thread block per tile compositing front to back from shared-memory batches.
// Backward: per tile, front to back again (as the CPU twin), per-splat gradients summed over each
// warp with a transposing shuffle reduction and one atomic per value and warp; then a per-Gaussian
// kernel chains them to the parameters.
// Include only from C++ files: no CUDA headers here. Not thread-safe; one instance per stream.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>

#include "chungs/render/gaussian_view.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_camera.hpp"
#include "chungs/render/render_output.hpp"

namespace chungs::cuda {

// Device arrays written by forward(); valid until the next forward. Images are row-major,
// interleaved like Image<T> (rgb: 3 floats per pixel).
struct DeviceRenderOutput {
  int width = 0, height = 0;
  size_t count = 0;  // rendered indices
  const float* rgb = nullptr;
  const float* depth = nullptr;
  const float* inv_depth = nullptr;
  const float* alpha = nullptr;
  const uint32_t* top_id = nullptr;
  const uint8_t* visible = nullptr;  // per rendered index
  const float* radius = nullptr;     // per rendered index
};

// dLoss/d(outputs) in device memory, shaped as the outputs; a null pointer means a zero gradient.
struct DeviceRenderGrads {
  const float* rgb = nullptr;
  const float* depth = nullptr;
  const float* inv_depth = nullptr;
  const float* alpha = nullptr;
};

// Compact gradients (entry j <-> ids[j]) in device memory, owned by the rasterizer.
struct DeviceGaussianGrads {
  size_t count = 0;
  float* mean = nullptr;       // 3 per entry
  float* log_scale = nullptr;  // 3
  float* rotation = nullptr;   // 4
  float* opacity = nullptr;    // 1
  float* sh = nullptr;         // 48
};

// Milliseconds of the stages of the last forward and backward, from device events recorded while
// timing is enabled; timings() waits for them, the calls themselves do not.
struct CudaRasterTimings {
  double preprocess = 0, sort = 0, composite = 0;  // forward
  double composite_backward = 0, project_backward = 0;
  // How the forward's tile entries were spread: a crowded tile is walked by one block alone.
  uint32_t largest_tile = 0;     // entries of the most crowded tile
  double top_percent_share = 0;  // share of all entries in the 1 % most crowded tiles
};

class CudaRasterizer {
 public:
  explicit CudaRasterizer(const RasterConfig& config = {});
  ~CudaRasterizer();
  CudaRasterizer(const CudaRasterizer&) = delete;
  CudaRasterizer& operator=(const CudaRasterizer&) = delete;

  const RasterConfig& config() const;
  void set_config(const RasterConfig& config);
  void enable_timings(bool on);

  // Renders Gaussians ids[0..n) of `g`; g's arrays and `ids` are device pointers. An index at or
  // above g.capacity throws Error naming it (checked on the device). The arrays must stay unchanged
  // until backward() for this render has run.
  const DeviceRenderOutput& forward(const GaussianArrays<float>& g, const uint32_t* ids, size_t n,
                                    const RenderCamera<float>& camera);

  // Gradients with respect to the Gaussians of the last forward; invisible entries get zeros.
  const DeviceGaussianGrads& backward(const DeviceRenderGrads& dloss);

  const DeviceRenderOutput& output() const;
  CudaRasterTimings timings() const;  // zeros for a stage not run with timing on
  size_t tile_entries() const;        // (tile, Gaussian) pairs of the last forward
  // Blocks of the last forward that composited a segment of a crowded tile (RasterConfig::segment_entries);
  // 0 when no tile was split. Waits for the forward.
  size_t split_items() const;

  // Copies of the device results into host types (for tests and tools).
  void download(RenderOutput<float>& out) const;
  void download(GaussianGrads<float>& grads) const;

 private:
  struct State;
  std::unique_ptr<State> s_;
};

}  // namespace chungs::cuda
