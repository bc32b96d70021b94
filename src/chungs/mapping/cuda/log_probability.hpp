// The sampler's probability maps on the GPU: the same functions as chungs::log_probability and
// chungs::sampling_probability (their CPU twins) on device images, so a keyframe's acceptance map is
// computed next to the render and only the 1-channel result goes to the host. No CUDA headers here:
// the kernels live in log_probability.cu; this header is also seen by it (C++17).
#pragma once
#include <cstddef>

#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda {

namespace detail {

// Kernel arguments for one LoG map; the launches run on the default stream and do not wait.
struct LogLaunch {
  int width, height, channels;
  const float* image;  // width x height x channels, interleaved
  float* blur_a;       // scratch, width x height x channels
  float* blur_b;       // scratch, width x height x channels
  float* lap;          // scratch, width x height
  float* out;          // width x height
  float inv_disc;      // 1 / (number of disc pixels), as the CPU twin computes it
};
void launch_log_probability(const LogLaunch& a);

// out = min(density * max(p - p_render, 0), 1), raised to empty_floor where alpha < 0.5; in place
// over p. p_render / alpha may be null (treated as no render / no alpha test).
void launch_penalty(float* p, const float* p_render, const float* alpha, size_t pixels, double density,
                    double empty_floor);

}  // namespace detail

class CudaLogProbability {
 public:
  // LoG probability of a device image (1-4 channels) into `out` (width * height floats, device).
  // Images smaller than 3x3 give zeros, as on the CPU. Returns without waiting for the device.
  void compute(const float* image, int width, int height, int channels, float* out);

  // The acceptance map density * max(P(image) - P(render), 0), at least empty_floor where
  // alpha < 0.5, at most 1, into `out` (device, width * height). render (3 channels) and alpha
  // (1 channel) are device images of the same size; either may be null. Returns without waiting.
  void sampling_probability(const float* image, int channels, const float* render, const float* alpha,
                            int width, int height, double density, double empty_floor, float* out);

 private:
  DeviceArray<float> blur_a_, blur_b_, lap_, p_render_;
};

}  // namespace chungs::cuda
