// The optimisation on the host: CpuGaussianPool, CpuRasterizer, the CPU loss and sparse Adam.
#pragma once
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/render/cpu/rasterizer.hpp"

namespace chungs {

class CpuOptimBackend final : public OptimBackend {
 public:
  CpuOptimBackend(size_t capacity, int sh_degree, const RasterConfig& raster);
  std::string name() const override { return "cpu"; }
  GaussianPool& pool() override { return pool_; }
  RenderOutput<float> render(std::span<const uint32_t> slots, const RenderCamera<float>& camera) override;
  LossTerms step(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                 const StepTargets& targets, const LossConfig& loss, const AdamConfig& adam,
                 const PruneConfig* prune, std::vector<uint32_t>& to_prune) override;
  ImageF sampling_probability(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                              const SamplerConfig& sampler, const ImageF& image) override;

 private:
  CpuGaussianPool pool_;
  CpuRasterizer<float> raster_;
  RenderGrads<float> dloss_;
  GaussianGrads<float> grads_;
};

}  // namespace chungs
