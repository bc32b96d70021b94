#include "chungs/mapping/cpu_backend.hpp"

#include "chungs/mapping/sampler.hpp"

namespace chungs {

CpuOptimBackend::CpuOptimBackend(size_t capacity, int sh_degree, const RasterConfig& raster)
    : pool_(capacity, sh_degree), raster_(raster) {}

RenderOutput<float> CpuOptimBackend::render(std::span<const uint32_t> slots,
                                            const RenderCamera<float>& camera) {
  return raster_.forward(view_of(pool_.params()), slots, camera);
}

ImageF CpuOptimBackend::sampling_probability(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                             const SamplerConfig& sampler, const ImageF& image) {
  const RenderOutput<float>& r = raster_.forward(view_of(pool_.params()), slots, camera);
  return chungs::sampling_probability(sampler, image, &r.rgb, &r.alpha);
}

LossTerms CpuOptimBackend::step(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                const StepTargets& targets, const LossConfig& loss, const AdamConfig& adam,
                                const PruneConfig* prune, std::vector<uint32_t>& to_prune) {
  to_prune.clear();
  const HostTargets t = host_targets(*targets.load(), targets.depth);
  const RenderOutput<float>& out = raster_.forward(view_of(pool_.params()), slots, camera);
  const LossTerms terms = mapping_loss<float>(loss, out, t.rgb, t.depth ? &t.inv_depth : nullptr,
                                              t.depth ? &t.mask : nullptr, &dloss_, targets.pixel_mask);
  if (slots.empty()) return terms;
  raster_.backward(dloss_, grads_);
  sparse_adam_step(adam, mut_view_of(pool_.params()), adam_state_of(pool_.storage()), slots, out.visible,
                   grads_);
  if (prune) to_prune = select_for_pruning(*prune, view_of(pool_.params()), slots, out.radius, camera.width);
  return terms;
}

}  // namespace chungs
