// The CPU reference rasterizer: forward render of a list of Gaussians (by slot index into SoA
// arrays) and the backward pass to their parameters. It keeps the intermediate state of the last
// forward for the backward, and reuses its buffers between calls. Not thread-safe: one instance per
// thread; it parallelises internally with OpenMP.
#pragma once
#include <cstdint>
#include <span>
#include <vector>

#include "chungs/render/cpu/binning.hpp"
#include "chungs/render/cpu/splat.hpp"
#include "chungs/render/gaussian_view.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_camera.hpp"
#include "chungs/render/render_output.hpp"

namespace chungs {

// Wall-clock milliseconds of the stages of the last calls (for benchmarks and profiling).
struct RasterTimings {
  double project = 0, bin = 0, composite = 0;  // forward
  double composite_backward = 0, project_backward = 0;
};

template <typename T>
class CpuRasterizer {
 public:
  explicit CpuRasterizer(const RasterConfig& config = {});

  const RasterConfig& config() const { return config_; }
  void set_config(const RasterConfig& config);

  // Renders Gaussians ids[0..n) of `g`. The returned output stays valid until the next forward. The
  // arrays behind `g` must stay unchanged until backward() for this render has run.
  const RenderOutput<T>& forward(const GaussianArrays<T>& g, std::span<const uint32_t> ids,
                                 const RenderCamera<T>& camera);

  // Gradients of the loss with respect to the parameters of the Gaussians of the last forward, given
  // dLoss/d(outputs). grads is resized to the number of rendered indices (entry j <-> ids[j]);
  // Gaussians that were not visible get zeros.
  void backward(const RenderGrads<T>& dloss, GaussianGrads<T>& grads);

  const RenderOutput<T>& output() const { return out_; }
  const RasterTimings& timings() const { return timings_; }
  // Number of (tile, splat) pairs of the last forward.
  size_t tile_entries() const { return bins_.list.size(); }

 private:
  RasterConfig config_;
  RasterConfig frame_config_;  // config_ for the last forward's image size (RasterConfig::low_pass_for)
  RenderOutput<T> out_;
  RasterTimings timings_;
  // State of the last forward.
  bool have_forward_ = false;
  GaussianArrays<T> g_;
  std::vector<uint32_t> ids_;
  RenderCamera<T> camera_;
  std::vector<cpu::Splat<T>> splats_;
  cpu::TileBins bins_;
  std::vector<uint32_t> last_;
  // Backward scratch.
  std::vector<T> splat_grads_;
  std::vector<std::vector<T>> thread_buffers_;
};

}  // namespace chungs
