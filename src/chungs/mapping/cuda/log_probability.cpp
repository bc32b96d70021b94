// Host side of the GPU LoG probability: argument checks and scratch buffers.
#ifdef CHUNGS_WITH_CUDA
#include "chungs/mapping/cuda/log_probability.hpp"

#include "chungs/common/error.hpp"

namespace chungs::cuda {

namespace {

// The disc of radius 3.5 inside the 7x7 window, counted as log_probability.cpp does.
float inverse_disc_size() {
  int n = 0;
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx)
      if (dx * dx + dy * dy <= 12.25) ++n;
  return 1.f / float(n);
}

}  // namespace

void CudaLogProbability::compute(const float* image, int width, int height, int channels, float* out) {
  if (width <= 0 || height <= 0) fail("CUDA LoG probability: image size ", width, "x", height, " is empty");
  if (channels < 1 || channels > 4) fail("CUDA LoG probability: ", channels, " channels (1-4 supported)");
  if (!image || !out) fail("CUDA LoG probability: null device image or output");
  const size_t plane = size_t(width) * height;
  if (width < 3 || height < 3) {
    fill_device_bytes(out, 0, plane * sizeof(float), "LoG probability of a tiny image");
    return;
  }
  blur_a_.resize(plane * channels);
  blur_b_.resize(plane * channels);
  lap_.resize(plane);
  detail::launch_log_probability(
      {width, height, channels, image, blur_a_.data(), blur_b_.data(), lap_.data(), out, inverse_disc_size()});
}

void CudaLogProbability::sampling_probability(const float* image, int channels, const float* render,
                                              const float* alpha, int width, int height, double density,
                                              double empty_floor, float* out) {
  if (!(density > 0)) fail("CUDA sampling probability: density must be > 0, got ", density);
  if (!(empty_floor >= 0 && empty_floor <= 1))
    fail("CUDA sampling probability: empty_floor must be in [0, 1], got ", empty_floor);
  compute(image, width, height, channels, out);
  if (render) {
    p_render_.resize(size_t(width) * height);
    compute(render, width, height, 3, p_render_.data());
  }
  detail::launch_penalty(out, render ? p_render_.data() : nullptr, alpha, size_t(width) * height, density,
                         empty_floor);
}

}  // namespace chungs::cuda
#endif
