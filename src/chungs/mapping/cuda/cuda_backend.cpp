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
                                   size_t target_cache_bytes)
    : pool_(capacity, sh_degree), raster_(raster), targets_(target_cache_bytes) {}

const DeviceRenderOutput& CudaOptimBackend::forward(std::span<const uint32_t> slots,
                                                    const RenderCamera<float>& camera) {
  ids_.upload(slots.data(), slots.size());
  pool_.wait_uploads();  // chunks scattered by Residency since the last render
  return raster_.forward(params_of(pool_.device_arrays(), 0), ids_.data(), slots.size(), camera);
}

RenderOutput<float> CudaOptimBackend::render(std::span<const uint32_t> slots,
                                             const RenderCamera<float>& camera) {
  const DeviceRenderOutput& r = forward(slots, camera);
  RenderOutput<float> out;
  raster_.download(out);
  if (!sky_.empty())
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
  to_prune.clear();
  const DeviceTargets t = targets_.expand(targets, target_rgb_, target_inv_, mask_);
  const bool depth = t.depth;
  const DeviceRenderOutput& out = forward(slots, camera);
  if (out.width != t.width || out.height != t.height)
    fail("cuda mapping step: target ", t.width, "x", t.height, " does not match the ", out.width, "x", out.height,
         " render");
  if (targets.pixel_mask) {
    if (targets.pixel_mask->width() != t.width || targets.pixel_mask->height() != t.height ||
        targets.pixel_mask->channels() != 1)
      fail("cuda mapping step: pixel mask ", targets.pixel_mask->width(), "x", targets.pixel_mask->height(),
           " does not match the ", t.width, "x", t.height, " target");
    pixel_mask_.upload(targets.pixel_mask->data(), targets.pixel_mask->pixels());
  }
  const bool sky = !sky_.empty();
  DeviceRenderOutput scored = out;
  if (sky) scored.rgb = sky_.compose(out, camera);
  const LossTerms terms = loss_.evaluate(loss, scored, target_rgb_.data(), depth ? target_inv_.data() : nullptr,
                                         depth ? mask_.data() : nullptr, sky || !slots.empty(),
                                         targets.pixel_mask ? pixel_mask_.data() : nullptr);
  DeviceRenderGrads grads = loss_.grads();
  if (sky) {
    // The alpha gradient the sky adds reaches the Gaussians through the rasterizer's backward.
    grads.alpha = sky_.backward(grads.rgb, out, camera);
    sky_.adam_step(sky_lr_);
  }
  if (slots.empty()) return terms;
  const DeviceGaussianGrads& g = raster_.backward(grads);
  const PoolDeviceArrays& d = pool_.device_arrays();
  const AdamState state{params_of(d, 1), params_of(d, 2), d.adam_steps, d.lr_position_factor, d.capacity};
  sparse_adam_step(adam, params_of(d, 0), state, ids_.data(), out.visible, slots.size(), g);
  if (prune) {
    // The rule reads only opacities (whole array: one copy), the screen radii of this render and, when
    // it waits for young Gaussians, the visit counts.
    opacity_.resize(d.capacity);
    copy_to_host(opacity_.data(), d.opacity[0], d.capacity * sizeof(float), "pruning opacities");
    radius_.resize(slots.size());
    copy_to_host(radius_.data(), out.radius, slots.size() * sizeof(float), "pruning radii");
    // select_for_pruning checks every pointer of the view; the other arrays are never read.
    const float* o = opacity_.data();
    const GaussianArrays<float> view{o, o, o, o, o, d.capacity};
    std::span<const uint32_t> visits;
    if (prune->min_visits > 0) {
      visits_.resize(d.capacity);
      copy_to_host(visits_.data(), d.adam_steps, d.capacity * sizeof(uint32_t), "pruning visit counts");
      visits = visits_;
    }
    to_prune = select_for_pruning(*prune, view, slots, radius_, camera.width, visits);
  }
  return terms;
}

std::optional<DeviceMemory> CudaOptimBackend::device_memory() const {
  size_t free_b = 0, total_b = 0;
  if (!device_memory_info(free_b, total_b)) return std::nullopt;
  return DeviceMemory{double(total_b - free_b) / 1048576.0, double(total_b) / 1048576.0};
}

}  // namespace chungs::cuda
#endif
