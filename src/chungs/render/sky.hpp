// The sky: what a pixel sees through the Gaussians, a colour per direction at infinity. Outdoors
// most of the image above the buildings has no depth; drawn by Gaussians at a fill depth, the sky
// of one keyframe stands in front of the street for the views that come after it, so they fade it,
// and only the views that made it keep it alive (under a memory budget they leave training first).
// A texture over directions lives outside the chunks, moves only with rotation like a real sky, and
// is trained by every step:
//   rgb = rgb_splats + (1 - alpha) * sky(direction of the pixel)
// so dL/dsky = dL/drgb * (1 - alpha) and dL/dalpha gains -dL/drgb . sky (the rasterizer's alpha
// gradient input chains it into the Gaussians). The texture is equirectangular in a frame whose
// pole is "up": the first keyframe's camera -y (cameras look level, y down).
// Float only: the CUDA twin (render/cuda/sky.hpp) calls the same inline taps.
#pragma once
#include <cmath>
#include <cstdint>
#include <vector>

#include "chungs/image/image.hpp"
#include "chungs/render/render_camera.hpp"

#ifdef __CUDACC__
#define CHUNGS_SKY_HD __host__ __device__
#else
#define CHUNGS_SKY_HD
#endif

namespace chungs {

struct SkyConfig {
  bool enabled = false;           // the outdoor preset turns it on
  int width = 256, height = 128;  // texels over azimuth (360 degrees) x elevation (180 degrees)
  double lr = 0.02;               // Adam step on texel colours
  void validate() const;          // throws Error naming the key
};

struct SkyTexture {
  int width = 0, height = 0;
  // Rows: the sky frame's east, north and up axes in world coordinates.
  float axes[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::vector<float> rgb, m1, m2;  // 3 per texel, row-major from the zenith; Adam moments
  std::vector<uint32_t> updates;   // per texel: Adam steps it took (only texels a step saw move)
  bool empty() const { return rgb.empty(); }
  size_t texels() const { return size_t(width) * size_t(height); }
  void check() const;  // sizes and finite values; throws Error
};

// A black sky (the background it replaces) with its pole along the camera's up (-y), for a
// camera-to-world rotation (row-major).
SkyTexture make_sky(const SkyConfig& config, const double R_wc[9]);

// Bilinear taps of the texture for a world direction (need not be unit): texel indices and weights.
struct SkyTap {
  uint32_t index[4];
  float weight[4];
};

CHUNGS_SKY_HD inline SkyTap sky_tap(const float* axes, int width, int height, float dx, float dy, float dz) {
  const float kPi = 3.14159265358979f;
  const float e = axes[0] * dx + axes[1] * dy + axes[2] * dz;
  const float n = axes[3] * dx + axes[4] * dy + axes[5] * dz;
  const float u = axes[6] * dx + axes[7] * dy + axes[8] * dz;
  const float az = atan2f(n, e);                     // -pi .. pi
  const float el = atan2f(u, sqrtf(e * e + n * n));  // -pi/2 .. pi/2
  // Texel centres at (i + 0.5) / size of the range; azimuth wraps, elevation clamps at the poles.
  float x = (az + kPi) * (float(width) / (2 * kPi)) - 0.5f;
  float y = (0.5f * kPi - el) * (float(height) / kPi) - 0.5f;
  y = fminf(fmaxf(y, 0.f), float(height - 1));
  const float fx0 = floorf(x), fy0 = floorf(y);
  const float ax = x - fx0, ay = y - fy0;
  int x0 = int(fx0) % width;
  if (x0 < 0) x0 += width;
  const int x1 = x0 + 1 == width ? 0 : x0 + 1;
  const int y0 = int(fy0), y1 = y0 + 1 < height ? y0 + 1 : y0;
  SkyTap t;
  t.index[0] = uint32_t(y0 * width + x0), t.weight[0] = (1 - ax) * (1 - ay);
  t.index[1] = uint32_t(y0 * width + x1), t.weight[1] = ax * (1 - ay);
  t.index[2] = uint32_t(y1 * width + x0), t.weight[2] = (1 - ax) * ay;
  t.index[3] = uint32_t(y1 * width + x1), t.weight[3] = ax * ay;
  return t;
}

// The taps of pixel (u, v) (its centre at (u, v), as the rasterizer's) of a render camera.
CHUNGS_SKY_HD inline SkyTap sky_pixel_tap(const float* axes, int width, int height,
                                          const RenderCamera<float>& c, int u, int v) {
  const float x = (float(u) - c.cx) / c.fx, y = (float(v) - c.cy) / c.fy;
  // World direction = R^T (x, y, 1), R world-to-camera row-major.
  const float dx = c.R[0] * x + c.R[3] * y + c.R[6];
  const float dy = c.R[1] * x + c.R[4] * y + c.R[7];
  const float dz = c.R[2] * x + c.R[5] * y + c.R[8];
  return sky_tap(axes, width, height, dx, dy, dz);
}

// A pixel whose gradient or coverage is not finite teaches the sky nothing (and gets no alpha
// gradient from it): one bad pixel would otherwise leave NaN moments in its texels for good.
CHUNGS_SKY_HD inline bool sky_finite(float x) {
#ifdef __CUDA_ARCH__
  return isfinite(x);
#else
  return std::isfinite(x);
#endif
}
CHUNGS_SKY_HD inline bool sky_pixel_usable(const float* grad_rgb, float clear) {
  return sky_finite(grad_rgb[0]) && sky_finite(grad_rgb[1]) && sky_finite(grad_rgb[2]) && sky_finite(clear);
}

// One texel's Adam step (betas 0.9, 0.999) on its 3 colours, bias-corrected by the steps that texel
// took; nothing when its gradient is zero (not seen by the step). Colours stay in [0, 1].
CHUNGS_SKY_HD inline void sky_adam_texel(float* rgb, float* m1, float* m2, uint32_t& updates, const float* g,
                                         float lr) {
  if (g[0] == 0 && g[1] == 0 && g[2] == 0) return;
  const uint32_t t = ++updates;
  const float c1 = float(1 / (1 - pow(0.9, double(t)))), c2 = float(1 / (1 - pow(0.999, double(t))));
  for (int c = 0; c < 3; ++c) {
    m1[c] = 0.9f * m1[c] + 0.1f * g[c];
    m2[c] = 0.999f * m2[c] + 0.001f * g[c] * g[c];
    const float x = rgb[c] - lr * (m1[c] * c1) / (sqrtf(m2[c] * c2) + 1e-15f);
    rgb[c] = fminf(fmaxf(x, 0.f), 1.f);
  }
}

// The sky's colour at every pixel of the camera (3 channels). With `taps`, every pixel's taps
// (row-major) are kept for sky_backward of the same camera, which then needs no trigonometry.
void sky_colours(const SkyTexture& sky, const RenderCamera<float>& camera, ImageF& out,
                 std::vector<SkyTap>* taps = nullptr);
// rgb += (1 - alpha) * sky_rgb.
void compose_sky(const ImageF& sky_rgb, const ImageF& alpha, ImageF& rgb);
// Given dL/d(composed rgb): grad_alpha = -dL/drgb . sky_rgb (written: the alpha gradient the
// rasterizer takes) and dL/d(texels) accumulated into grad_texels (3 per texel, sized by the caller).
// Per-thread sums, added in thread order, so the result does not depend on the timing.
void sky_backward(const SkyTexture& sky, const RenderCamera<float>& camera, const ImageF& sky_rgb,
                  const ImageF& alpha, const ImageF& grad_rgb, ImageF& grad_alpha,
                  std::vector<float>& grad_texels, const std::vector<SkyTap>* taps = nullptr);
// Adam (betas 0.9, 0.999) on the texels whose gradient is non-zero (the others were not seen, and
// keep their moments); colours kept in [0, 1].
void sky_adam_step(SkyTexture& sky, const std::vector<float>& grad, double lr);

}  // namespace chungs
