// Kernels of CudaSky: one thread per pixel for the composite and its backward (texel gradients by
// atomics: only pixels the Gaussians leave partly clear reach the texture), one per texel for Adam.
#include <cuda_runtime.h>

#include <cstring>

#include "chungs/common/error.hpp"
#include "chungs/render/cuda/sky.hpp"

namespace chungs::cuda {

namespace {

struct SkyArgs {
  float axes[9];
  int width, height;
};

__global__ void compose_kernel(SkyArgs s, const float* __restrict__ tex, RenderCamera<float> cam,
                               const float* __restrict__ rgb, const float* __restrict__ alpha,
                               float* __restrict__ sky_px, float* __restrict__ out) {
  const int p = blockIdx.x * blockDim.x + threadIdx.x;
  if (p >= cam.width * cam.height) return;
  const SkyTap t = sky_pixel_tap(s.axes, s.width, s.height, cam, p % cam.width, p / cam.width);
  const float clear = 1.f - alpha[p];
  for (int c = 0; c < 3; ++c) {
    float v = 0;
    for (int k = 0; k < 4; ++k) v += t.weight[k] * tex[3 * size_t(t.index[k]) + c];
    sky_px[3 * size_t(p) + c] = v;
    out[3 * size_t(p) + c] = rgb[3 * size_t(p) + c] + clear * v;
  }
}

__global__ void backward_kernel(SkyArgs s, RenderCamera<float> cam, const float* __restrict__ sky_px,
                                const float* __restrict__ alpha, const float* __restrict__ g,
                                float* __restrict__ grad_alpha, float* __restrict__ grad_tex) {
  const int p = blockIdx.x * blockDim.x + threadIdx.x;
  if (p >= cam.width * cam.height) return;
  const float* gp = g + 3 * size_t(p);
  const float clear = 1.f - alpha[p];
  if (!sky_pixel_usable(gp, clear)) {
    grad_alpha[p] = 0.f;
    return;
  }
  float ga = 0;
  for (int c = 0; c < 3; ++c) ga -= gp[c] * sky_px[3 * size_t(p) + c];
  grad_alpha[p] = ga;
  if (clear <= 0.f || (gp[0] == 0.f && gp[1] == 0.f && gp[2] == 0.f)) return;
  const SkyTap t = sky_pixel_tap(s.axes, s.width, s.height, cam, p % cam.width, p / cam.width);
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) atomicAdd(&grad_tex[3 * size_t(t.index[k]) + c], t.weight[k] * clear * gp[c]);
}

__global__ void adam_kernel(int n, float* rgb, float* m1, float* m2, uint32_t* updates, const float* g,
                            float lr) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  sky_adam_texel(rgb + 3 * size_t(i), m1 + 3 * size_t(i), m2 + 3 * size_t(i), updates[i], g + 3 * size_t(i),
                 lr);
}

unsigned blocks_for(size_t n, unsigned threads) { return unsigned((n + threads - 1) / threads); }

}  // namespace

void CudaSky::upload(const SkyTexture& sky) {
  sky.check();
  width_ = sky.width;
  height_ = sky.height;
  std::memcpy(axes_, sky.axes, sizeof axes_);
  rgb_.upload(sky.rgb);
  m1_.upload(sky.m1);
  m2_.upload(sky.m2);
  updates_.upload(sky.updates);
  grad_.resize(sky.rgb.size());
}

void CudaSky::download(SkyTexture& sky) const {
  sky.width = width_;
  sky.height = height_;
  std::memcpy(sky.axes, axes_, sizeof axes_);
  rgb_.download(sky.rgb);
  m1_.download(sky.m1);
  m2_.download(sky.m2);
  updates_.download(sky.updates);
}

const float* CudaSky::compose(const DeviceRenderOutput& r, const RenderCamera<float>& camera) {
  if (empty()) fail("CUDA sky: no texture uploaded");
  const size_t n = size_t(r.width) * size_t(r.height);
  if (r.width != camera.width || r.height != camera.height)
    fail("CUDA sky: render and camera differ in size");
  composed_.resize(3 * n);
  sky_px_.resize(3 * n);
  SkyArgs s;
  std::memcpy(s.axes, axes_, sizeof axes_);
  s.width = width_, s.height = height_;
  compose_kernel<<<blocks_for(n, 256), 256>>>(s, rgb_.data(), camera, r.rgb, r.alpha, sky_px_.data(),
                                              composed_.data());
  check_last("CUDA sky: compose");
  return composed_.data();
}

const float* CudaSky::backward(const float* grad_rgb, const DeviceRenderOutput& r,
                               const RenderCamera<float>& camera) {
  const size_t n = size_t(r.width) * size_t(r.height);
  if (sky_px_.size() != 3 * n) fail("CUDA sky: backward without a compose of this render");
  grad_alpha_.resize(n);
  fill_device_bytes(grad_.data(), 0, grad_.size() * sizeof(float), "CUDA sky: texel gradient");
  SkyArgs s;
  std::memcpy(s.axes, axes_, sizeof axes_);
  s.width = width_, s.height = height_;
  backward_kernel<<<blocks_for(n, 256), 256>>>(s, camera, sky_px_.data(), r.alpha, grad_rgb,
                                               grad_alpha_.data(), grad_.data());
  check_last("CUDA sky: backward");
  return grad_alpha_.data();
}

void CudaSky::adam_step(double lr) {
  const int n = width_ * height_;
  adam_kernel<<<blocks_for(size_t(n), 256), 256>>>(n, rgb_.data(), m1_.data(), m2_.data(), updates_.data(),
                                                   grad_.data(), float(lr));
  check_last("CUDA sky: Adam step");
}

}  // namespace chungs::cuda
