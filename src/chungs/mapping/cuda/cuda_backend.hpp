// The optimisation on the GPU: CudaGaussianPool (VRAM slots; Residency loads and evicts chunks through
// its host<->device copies), CudaRasterizer, the fused CUDA loss and fused sparse Adam. Per step only
// the slot list goes up (keyframe images stay in DeviceTargetCache), and only the loss sums come back (plus
// the selected places on pruning steps); render() downloads the images for the evaluation; the sampler's map
// is computed on the device. Built only with CHUNGS_WITH_CUDA; no CUDA headers here.
#pragma once
#include "chungs/mapping/cuda/log_probability.hpp"
#include "chungs/mapping/cuda/slot_order.hpp"
#include "chungs/mapping/cuda/target_cache.hpp"
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/mapping/step_phases.hpp"
#include "chungs/optim/cuda/loss.hpp"
#include "chungs/optim/cuda/prune.hpp"
#include "chungs/render/cuda/device_buffer.hpp"
#include "chungs/render/cuda/rasterizer.hpp"
#include "chungs/render/cuda/sky.hpp"
#include "chungs/residency/cuda/gaussian_pool.hpp"

namespace chungs::cuda {

class CudaOptimBackend final : public OptimBackend {
 public:
  CudaOptimBackend(size_t capacity, int sh_degree, const RasterConfig& raster, size_t target_cache_bytes = 0,
                   size_t target_cache_entries = SIZE_MAX);
  std::string name() const override { return "cuda"; }
  GaussianPool& pool() override { return pool_; }
  RenderOutput<float> render(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                             bool with_sky) override;
  std::span<uint32_t> slot_buffer(size_t n) override;
  LossTerms step(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                 const StepTargets& targets, const LossConfig& loss, const AdamConfig& adam,
                 const PruneConfig* prune, std::vector<uint32_t>& to_prune) override;
  ImageF sampling_probability(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                              const SamplerConfig& sampler, const ImageF& image) override;
  std::optional<DeviceMemory> device_memory() const override;
  void set_sky(const SkyTexture& sky, double lr) override;
  std::optional<SkyTexture> sky() const override;
  void set_profiling(bool on) override;
  void set_raster_config(const RasterConfig& raster) override { raster_.set_config(raster); }
  const StepPhaseTimes& phase_times() const override { return clock_.times(); }

 private:
  const DeviceRenderOutput& forward(std::span<const uint32_t> slots, const RenderCamera<float>& camera);
  void upload_slots(std::span<const uint32_t> slots);
  // Phase boundaries while profiling: host clock and a device event each (see StepPhaseTimes).
  void begin_phases();
  void mark(StepPhaseTimes::Phase phase);
  void end_phases();

  CudaGaussianPool pool_;
  CudaRasterizer raster_;
  CudaMappingLoss loss_;
  CudaLogProbability log_probability_;
  CudaSky sky_;
  double sky_lr_ = 0;
  DeviceTargetCache targets_;
  StagedUpload staging_;  // the slot list goes up without holding the host or the default stream
  const uint32_t* ids_ = nullptr;  // the device copy of the last slot list
  SlotOrder ordered_;              // a step's list in slot order: what its kernels read
  DeviceArray<float> target_rgb_, target_inv_, probability_;
  DeviceArray<uint8_t> mask_;
  StagedUpload mask_staging_;  // a trimmed step's pixel mask, as the slot list
  CudaPruneSelector pruner_;
  StepPhaseClock clock_;
  std::unique_ptr<BoundaryEvents> events_;  // while profiling
  std::vector<StepPhaseTimes::Phase> marked_;  // phase ended at each recorded boundary after the first
};

}  // namespace chungs::cuda
