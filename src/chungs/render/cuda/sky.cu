// Kernels of CudaSky: one thread per pixel for the composite and its backward (texel gradients summed
// per block, then by atomics: only pixels the Gaussians leave partly clear reach the texture), one per
// texel for Adam.
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

// Texel gradients are summed per block in a small shared-memory table before they reach global
// memory: the sky covers a few hundred texels of a view, so every texel would otherwise take the
// atomics of hundreds of pixels (0.28 ms a step at KITTI's size on an H100, most of it contention).
// A block's 256 consecutive pixels touch a few dozen texels; a texel that finds the table full goes
// straight to global memory.
constexpr int kTableSlots = 256;
constexpr uint32_t kFree = 0xFFFFFFFFu;

__device__ void add_texel(uint32_t* keys, float (*acc)[3], uint32_t texel, const float v[3],
                          float* __restrict__ grad_tex) {
  uint32_t h = (texel * 2654435761u) % kTableSlots;
  for (int probe = 0; probe < 8; ++probe, h = (h + 1) % kTableSlots) {
    const uint32_t prev = atomicCAS(&keys[h], kFree, texel);
    if (prev == kFree || prev == texel) {
      for (int c = 0; c < 3; ++c) atomicAdd(&acc[h][c], v[c]);
      return;
    }
  }
  for (int c = 0; c < 3; ++c) atomicAdd(&grad_tex[3 * size_t(texel) + c], v[c]);
}

__global__ void __launch_bounds__(256) backward_kernel(SkyArgs s, RenderCamera<float> cam,
                                                       const float* __restrict__ sky_px,
                                                       const float* __restrict__ alpha, const float* __restrict__ g,
                                                       float* __restrict__ grad_alpha, float* __restrict__ grad_tex) {
  __shared__ uint32_t keys[kTableSlots];
  __shared__ float acc[kTableSlots][3];
  __shared__ float lanes[8][32][3];  // a warp's values of one tap, summed by the lane that leads each texel
  for (int i = threadIdx.x; i < kTableSlots; i += blockDim.x) {
    keys[i] = kFree;
    acc[i][0] = acc[i][1] = acc[i][2] = 0.f;
  }
  __syncthreads();
  const int p = blockIdx.x * blockDim.x + threadIdx.x;
  const int warp = threadIdx.x >> 5, lane = threadIdx.x & 31;
  bool teaches = false;
  float clear = 0.f;
  const float* gp = nullptr;
  if (p < cam.width * cam.height) {
    gp = g + 3 * size_t(p);
    clear = 1.f - alpha[p];
    if (!sky_pixel_usable(gp, clear)) {
      grad_alpha[p] = 0.f;
    } else {
      float ga = 0;
      for (int c = 0; c < 3; ++c) ga -= gp[c] * sky_px[3 * size_t(p) + c];
      grad_alpha[p] = ga;
      teaches = clear > 0.f && (gp[0] != 0.f || gp[1] != 0.f || gp[2] != 0.f);
    }
  }
  SkyTap t{};
  if (teaches) t = sky_pixel_tap(s.axes, s.width, s.height, cam, p % cam.width, p / cam.width);
  // Neighbouring pixels share texels: the lanes of a warp with the same texel are summed first, and only
  // their leader goes to the block's table.
  for (int k = 0; k < 4; ++k) {
    const uint32_t key = teaches ? t.index[k] : kFree;
    const float w = teaches ? t.weight[k] * clear : 0.f;
    for (int c = 0; c < 3; ++c) lanes[warp][lane][c] = teaches ? w * gp[c] : 0.f;
    const unsigned peers = __match_any_sync(0xffffffffu, key);
    __syncwarp();
    if (key != kFree && lane == __ffs(peers) - 1) {
      float v[3] = {0.f, 0.f, 0.f};
      for (unsigned m = peers; m; m &= m - 1)
        for (int c = 0; c < 3; ++c) v[c] += lanes[warp][__ffs(m) - 1][c];
      add_texel(keys, acc, key, v, grad_tex);
    }
    __syncwarp();
  }
  __syncthreads();
  for (int i = threadIdx.x; i < kTableSlots; i += blockDim.x)
    if (keys[i] != kFree)
      for (int c = 0; c < 3; ++c) atomicAdd(&grad_tex[3 * size_t(keys[i]) + c], acc[i][c]);
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
