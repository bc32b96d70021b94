// The optimisation on the host: CpuGaussianPool, CpuRasterizer, the CPU loss and sparse Adam.
#pragma once
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/mapping/step_phases.hpp"
#include "chungs/render/cpu/rasterizer.hpp"

namespace chungs {

class CpuOptimBackend final : public OptimBackend {
 public:
  CpuOptimBackend(size_t capacity, int sh_degree, const RasterConfig& raster);
  std::string name() const override { return "cpu"; }
  GaussianPool& pool() override { return pool_; }
  RenderOutput<float> render(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                             bool with_sky) override;
  std::span<uint32_t> slot_buffer(size_t n) override;
  LossTerms step(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                 const StepTargets& targets, const LossConfig& loss, const AdamConfig& adam,
                 const PruneConfig* prune, std::vector<uint32_t>& to_prune) override;
  ImageF sampling_probability(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                              const SamplerConfig& sampler, const ImageF& image) override;
  void set_sky(const SkyTexture& sky, double lr) override;
  std::optional<SkyTexture> sky() const override { return sky_; }
  void set_profiling(bool on) override { clock_.set_on(on); }
  void set_raster_config(const RasterConfig& raster) override { raster_.set_config(raster); }
  const StepPhaseTimes& phase_times() const override { return clock_.times(); }

 private:
  CpuGaussianPool pool_;
  CpuRasterizer<float> raster_;
  RenderGrads<float> dloss_;
  GaussianGrads<float> grads_;
  std::optional<SkyTexture> sky_;
  double sky_lr_ = 0;
  ImageF sky_px_;                  // the sky's colour per pixel of the last render
  RenderOutput<float> composed_;   // rgb with the sky behind it (and the inverse depth), for the loss
  std::vector<float> sky_grad_;
  std::vector<SkyTap> sky_taps_;  // of the last step's camera, shared by its forward and backward
  StepPhaseClock clock_;
  std::vector<uint32_t> slot_list_;  // slot_buffer()'s
};

}  // namespace chungs
