#if CHUNGS_WITH_CUDA
#include "chungs/mapping/cuda/cuda_backend.hpp"

#include "chungs/mapping/cuda/device_memory.hpp"
#include "chungs/mapping/sampler.hpp"
#include "chungs/optim/cuda/adam.hpp"

namespace chungs::cuda {

namespace {

GaussianArraysMut<float> params_of(const PoolDeviceArrays& d, int k) {
  return {d.mean[k], d.log_scale[k], d.rotation[k], d.opacity[k], d.sh[k], d.capacity};
}

}  // namespace

CudaOptimBackend::CudaOptimBackend(size_t capacity, int sh_degree, const RasterConfig& raster,
                                   size_t target_cache_bytes, size_t target_cache_entries)
    : pool_(capacity, sh_degree), raster_(raster), targets_(target_cache_bytes, target_cache_entries) {}

std::span<uint32_t> CudaOptimBackend::slot_buffer(size_t n) {
  return {static_cast<uint32_t*>(staging_.next_host_buffer(n * sizeof(uint32_t), "slot list")), n};
}

void CudaOptimBackend::upload_slots(std::span<const uint32_t> slots) {
  ids_ = static_cast<const uint32_t*>(staging_.upload(slots.data(), slots.size_bytes(), "slot list"));
  pool_.wait_uploads();  // chunks scattered by Residency since the last render
}

const DeviceRenderOutput& CudaOptimBackend::forward(std::span<const uint32_t> slots,
                                                    const RenderCamera<float>& camera) {
  upload_slots(slots);
  return raster_.forward(params_of(pool_.device_arrays(), 0), ids_, slots.size(), camera);
}

void CudaOptimBackend::set_profiling(bool on) {
  clock_.set_on(on);
  raster_.enable_timings(on);
  if (on && !events_) events_ = std::make_unique<BoundaryEvents>(int(StepPhaseTimes::count) + 1);
}

void CudaOptimBackend::begin_phases() {
  if (!clock_.on()) return;
  clock_.begin();
  marked_.clear();
  events_->record(0);
}

void CudaOptimBackend::mark(StepPhaseTimes::Phase phase) {
  if (!clock_.on()) return;
  clock_.mark(phase);
  marked_.push_back(phase);
  events_->record(int(marked_.size()));
}

void CudaOptimBackend::end_phases() {
  if (!clock_.on()) return;
  StepPhaseTimes& t = clock_.times();
  for (size_t i = 0; i < marked_.size(); ++i) t.device_ms[marked_[i]] += events_->elapsed_ms(int(i), int(i) + 1);
  if (!marked_.empty()) t.device_span_ms += events_->elapsed_ms(0, int(marked_.size()));
  const cuda::CudaRasterTimings r = raster_.timings();
  const double stages[StepPhaseTimes::stage_count] = {r.preprocess, r.sort, r.composite, r.composite_backward,
                                                      r.project_backward};
  for (int i = 0; i < StepPhaseTimes::stage_count; ++i) t.stage_ms[i] += stages[i];
  t.tile_entries += double(raster_.tile_entries());
  t.largest_tile += double(r.largest_tile), t.top_percent_share += r.top_percent_share;
  clock_.end();
}

RenderOutput<float> CudaOptimBackend::render(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                             bool with_sky) {
  const DeviceRenderOutput& r = forward(slots, camera);
  RenderOutput<float> out;
  raster_.download(out);
  if (!sky_.empty() && with_sky)
    copy_to_host(out.rgb.data(), sky_.compose(r, camera), out.rgb.size() * sizeof(float), "render with the sky");
  return out;
}

void CudaOptimBackend::set_sky(const SkyTexture& sky, double lr) {
  sky_.upload(sky);
  sky_lr_ = lr;
}

std::optional<SkyTexture> CudaOptimBackend::sky() const {
  if (sky_.empty()) return std::nullopt;
  SkyTexture s;
  sky_.download(s);
  return s;
}

ImageF CudaOptimBackend::sampling_probability(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                              const SamplerConfig& sampler, const ImageF& image) {
  sampler.validate();
  const DeviceRenderOutput& out = forward(slots, camera);
  if (out.width != image.width() || out.height != image.height())
    fail("sampler: render and keyframe image differ in size (", out.width, "x", out.height, " vs ",
         image.width(), "x", image.height(), ")");
  // The keyframe goes up once and only the 1-channel map comes back (not the render's images).
  target_rgb_.upload(image.data(), image.size());
  probability_.resize(size_t(image.width()) * image.height());
  const float* rgb = sky_.empty() ? out.rgb : sky_.compose(out, camera);
  log_probability_.sampling_probability(target_rgb_.data(), image.channels(), rgb, out.alpha, out.width,
                                        out.height, sampler.density, sampler.empty_floor, probability_.data());
  ImageF p(image.width(), image.height(), 1);
  probability_.download(p.vec());
  return p;
}

LossTerms CudaOptimBackend::step(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                 const StepTargets& targets, const LossConfig& loss, const AdamConfig& adam,
                                 const PruneConfig* prune, std::vector<uint32_t>& to_prune) {
  using P = StepPhaseTimes;
  begin_phases();
  to_prune.clear();
  const DeviceTargets t = targets_.expand(targets, target_rgb_, target_inv_, mask_);
  const bool depth = t.depth;
  mark(P::targets);
  upload_slots(slots);
  const uint8_t* pixel_mask = nullptr;
  if (targets.pixel_mask) {
    if (targets.pixel_mask->width() != t.width || targets.pixel_mask->height() != t.height ||
        targets.pixel_mask->channels() != 1)
      fail("cuda mapping step: pixel mask ", targets.pixel_mask->width(), "x", targets.pixel_mask->height(),
           " does not match the ", t.width, "x", t.height, " target");
    pixel_mask = static_cast<const uint8_t*>(
        mask_staging_.upload(targets.pixel_mask->data(), targets.pixel_mask->pixels(), "pixel mask"));
  }
  // The step's kernels read the list in slot order (slot_order.hpp); pruning reports the places in `slots`.
  ordered_.sort(ids_, slots.size(), pool_.device_arrays().capacity);
  mark(P::upload);
  const DeviceRenderOutput& out =
      raster_.forward(params_of(pool_.device_arrays(), 0), ordered_.ids(), slots.size(), camera);
  mark(P::forward);
  if (out.width != t.width || out.height != t.height)
    fail("cuda mapping step: target ", t.width, "x", t.height, " does not match the ", out.width, "x", out.height,
         " render");
  const bool sky = !sky_.empty();
  DeviceRenderOutput scored = out;
  if (sky) scored.rgb = sky_.compose(out, camera);
  // The loss sums are read only after the backward and Adam are queued: the host's wait for them
  // then overlaps the device's work instead of leaving the device idle until the next launch.
  loss_.launch(loss, scored, target_rgb_.data(), depth ? target_inv_.data() : nullptr,
               depth ? mask_.data() : nullptr, sky || !slots.empty(), pixel_mask);
  DeviceRenderGrads grads = loss_.grads();
  mark(P::loss);
  if (sky) {
    // The alpha gradient the sky adds reaches the Gaussians through the rasterizer's backward.
    grads.alpha = sky_.backward(grads.rgb, out, camera);
    sky_.adam_step(sky_lr_);
    mark(P::sky);
  }
  if (slots.empty()) {
    const LossTerms terms = loss_.finish();
    end_phases();
    return terms;
  }
  const DeviceGaussianGrads& g = raster_.backward(grads);
  mark(P::backward);
  const PoolDeviceArrays& d = pool_.device_arrays();
  const AdamState state{params_of(d, 1), params_of(d, 2), d.adam_steps, d.lr_position_factor, d.capacity};
  // The forward above refused out-of-range slots of this same list: Adam need not wait to check.
  sparse_adam_step(adam, params_of(d, 0), state, ordered_.ids(), out.visible, slots.size(), g,
                   /*ids_checked=*/true);
  mark(P::adam);
  if (prune) {
    // On the device: only the selected places come back (cuda/prune.hpp).
    pruner_.select(*prune, d.opacity[0], d.capacity, ordered_.ids(), slots.size(), out.radius, camera.width,
                   prune->min_visits > 0 ? d.adam_steps : nullptr, ordered_.places(), to_prune);
    mark(P::prune);
  }
  const LossTerms terms = loss_.finish();
  end_phases();
  return terms;
}

std::optional<DeviceMemory> CudaOptimBackend::device_memory() const {
  size_t free_b = 0, total_b = 0;
  if (!device_memory_info(free_b, total_b)) return std::nullopt;
  return DeviceMemory{double(total_b - free_b) / 1048576.0, double(total_b) / 1048576.0};
}

}  // namespace chungs::cuda
#endif
