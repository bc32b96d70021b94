#include "chungs/mapping/cpu_backend.hpp"

#include "chungs/mapping/sampler.hpp"

namespace chungs {

CpuOptimBackend::CpuOptimBackend(size_t capacity, int sh_degree, const RasterConfig& raster)
    : pool_(capacity, sh_degree), raster_(raster) {}

void CpuOptimBackend::set_sky(const SkyTexture& sky, double lr) {
  sky.check();
  sky_ = sky;
  sky_lr_ = lr;
}

RenderOutput<float> CpuOptimBackend::render(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                            bool with_sky) {
  RenderOutput<float> out = raster_.forward(view_of(pool_.params()), slots, camera);
  if (sky_ && with_sky) {
    sky_colours(*sky_, camera, sky_px_);
    compose_sky(sky_px_, out.alpha, out.rgb);
  }
  return out;
}

ImageF CpuOptimBackend::sampling_probability(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                             const SamplerConfig& sampler, const ImageF& image) {
  const RenderOutput<float>& r = raster_.forward(view_of(pool_.params()), slots, camera);
  if (!sky_) return chungs::sampling_probability(sampler, image, &r.rgb, &r.alpha);
  sky_colours(*sky_, camera, sky_px_);
  composed_.rgb = r.rgb;
  compose_sky(sky_px_, r.alpha, composed_.rgb);
  return chungs::sampling_probability(sampler, image, &composed_.rgb, &r.alpha);
}

std::span<uint32_t> CpuOptimBackend::slot_buffer(size_t n) {
  slot_list_.resize(n);
  return slot_list_;
}

LossTerms CpuOptimBackend::step(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                const StepTargets& targets, const LossConfig& loss, const AdamConfig& adam,
                                const PruneConfig* prune, std::vector<uint32_t>& to_prune) {
  using P = StepPhaseTimes;
  clock_.begin();
  to_prune.clear();
  const HostTargets t = host_targets(*targets.load(), targets.depth);
  clock_.mark(P::targets);
  const RenderOutput<float>& out = raster_.forward(view_of(pool_.params()), slots, camera);
  clock_.mark(P::forward);
  const RenderOutput<float>* scored = &out;
  if (sky_) {
    sky_colours(*sky_, camera, sky_px_, &sky_taps_);
    composed_.rgb = out.rgb;
    composed_.inv_depth = out.inv_depth;
    compose_sky(sky_px_, out.alpha, composed_.rgb);
    scored = &composed_;
  }
  const LossTerms terms = mapping_loss<float>(loss, *scored, t.rgb, t.depth ? &t.inv_depth : nullptr,
                                              t.depth ? &t.mask : nullptr, &dloss_, targets.pixel_mask);
  clock_.mark(P::loss);
  if (sky_) {
    // The alpha gradient the sky adds reaches the Gaussians through the rasterizer's backward.
    sky_grad_.assign(3 * sky_->texels(), 0.f);
    sky_backward(*sky_, camera, sky_px_, out.alpha, dloss_.rgb, dloss_.alpha, sky_grad_, &sky_taps_);
    sky_adam_step(*sky_, sky_grad_, sky_lr_);
    clock_.mark(P::sky);
  }
  if (!slots.empty()) {
    raster_.backward(dloss_, grads_);
    clock_.mark(P::backward);
    sparse_adam_step(adam, mut_view_of(pool_.params()), adam_state_of(pool_.storage()), slots, out.visible,
                     grads_);
    clock_.mark(P::adam);
    if (prune)
      to_prune = select_for_pruning(*prune, view_of(pool_.params()), slots, out.radius, camera.width,
                                    pool_.storage().adam_steps);
    clock_.mark(P::prune);
  }
  clock_.end();
  return terms;
}

}  // namespace chungs
