// The sky on the GPU: the same function as render/sky.hpp (its CPU twin, the reference of the
// parity test), over device images of a CudaRasterizer render. Include only from C++ files.
#pragma once
#include <cstdint>

#include "chungs/render/cuda/device_buffer.hpp"
#include "chungs/render/cuda/rasterizer.hpp"
#include "chungs/render/sky.hpp"

namespace chungs::cuda {

class CudaSky {
 public:
  void upload(const SkyTexture& sky);    // texels, moments and step counts
  void download(SkyTexture& sky) const;  // into a texture of the same size (its frame copied)
  bool empty() const { return width_ == 0; }

  // rgb + (1 - alpha) * sky of the render (device, 3 floats per pixel), valid until the next call.
  const float* compose(const DeviceRenderOutput& render, const RenderCamera<float>& camera);
  // After compose() of the same render: dL/dalpha (device, 1 per pixel, the rasterizer's alpha
  // gradient) from dL/d(composed rgb); the texel gradients are kept for adam_step().
  const float* backward(const float* grad_rgb, const DeviceRenderOutput& render,
                        const RenderCamera<float>& camera);
  void adam_step(double lr);  // on the gradients of the last backward()

 private:
  int width_ = 0, height_ = 0;
  float axes_[9] = {};
  DeviceArray<float> rgb_, m1_, m2_, grad_, composed_, sky_px_, grad_alpha_;
  DeviceArray<uint32_t> updates_;
};

}  // namespace chungs::cuda
