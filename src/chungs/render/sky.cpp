#include "chungs/render/sky.hpp"

#include <omp.h>

#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

void SkyConfig::validate() const {
  if (width < 4 || width > 4096) fail("sky: width must be in [4, 4096] texels, got ", width);
  if (height < 2 || height > 2048) fail("sky: height must be in [2, 2048] texels, got ", height);
  if (!(lr > 0 && lr <= 1)) fail("sky: lr must be in (0, 1], got ", lr);
}

void SkyTexture::check() const {
  if (width < 4 || width > 4096 || height < 2 || height > 2048)
    fail("sky texture: ", width, "x", height, " texels is outside 4x2 .. 4096x2048");
  const size_t n = 3 * texels();
  if (rgb.size() != n || m1.size() != n || m2.size() != n || updates.size() != texels())
    fail("sky texture: arrays do not match ", width, "x", height, " texels");
  for (float a : axes)
    if (!std::isfinite(a)) fail("sky texture: its frame axes are not finite");
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(rgb[i]) || !std::isfinite(m1[i]) || !(m2[i] >= 0 && std::isfinite(m2[i])))
      fail("sky texture: texel ", i / 3, " holds a non-finite value");
}

SkyTexture make_sky(const SkyConfig& config, const double R_wc[9]) {
  config.validate();
  SkyTexture s;
  s.width = config.width;
  s.height = config.height;
  // Camera x (east) and -y (up) in the world: columns of the camera-to-world rotation.
  double e[3] = {R_wc[0], R_wc[3], R_wc[6]}, u[3] = {-R_wc[1], -R_wc[4], -R_wc[7]};
  const double ne = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  const double nu = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  if (!(ne > 0.5 && ne < 2 && nu > 0.5 && nu < 2))
    fail("sky: the first keyframe's rotation is not a rotation");
  for (int i = 0; i < 3; ++i) e[i] /= ne, u[i] /= nu;
  const double n[3] = {u[1] * e[2] - u[2] * e[1], u[2] * e[0] - u[0] * e[2], u[0] * e[1] - u[1] * e[0]};
  for (int i = 0; i < 3; ++i) {
    s.axes[i] = float(e[i]);
    s.axes[3 + i] = float(n[i]);
    s.axes[6 + i] = float(u[i]);
  }
  s.rgb.assign(3 * s.texels(), 0.f);
  s.m1.assign(3 * s.texels(), 0.f);
  s.m2.assign(3 * s.texels(), 0.f);
  s.updates.assign(s.texels(), 0);
  return s;
}

void sky_colours(const SkyTexture& sky, const RenderCamera<float>& camera, ImageF& out,
                 std::vector<SkyTap>* taps) {
  if (out.width() != camera.width || out.height() != camera.height || out.channels() != 3)
    out = ImageF(camera.width, camera.height, 3);
  if (taps) taps->resize(size_t(camera.width) * size_t(camera.height));
#pragma omp parallel for schedule(static)
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) {
      const SkyTap t = sky_pixel_tap(sky.axes, sky.width, sky.height, camera, u, v);
      if (taps) (*taps)[size_t(v) * size_t(camera.width) + size_t(u)] = t;
      for (int c = 0; c < 3; ++c) {
        float s = 0;
        for (int k = 0; k < 4; ++k) s += t.weight[k] * sky.rgb[3 * size_t(t.index[k]) + size_t(c)];
        out(u, v, c) = s;
      }
    }
}

void compose_sky(const ImageF& sky_rgb, const ImageF& alpha, ImageF& rgb) {
  if (!sky_rgb.same_size(rgb) || sky_rgb.channels() != 3 || rgb.channels() != 3 ||
      alpha.width() != rgb.width() || alpha.height() != rgb.height())
    fail("sky: sky, alpha and rgb images differ in size");
  for (int v = 0; v < rgb.height(); ++v)
    for (int u = 0; u < rgb.width(); ++u) {
      const float clear = 1 - alpha(u, v);
      for (int c = 0; c < 3; ++c) rgb(u, v, c) += clear * sky_rgb(u, v, c);
    }
}

void sky_backward(const SkyTexture& sky, const RenderCamera<float>& camera, const ImageF& sky_rgb,
                  const ImageF& alpha, const ImageF& grad_rgb, ImageF& grad_alpha,
                  std::vector<float>& grad_texels, const std::vector<SkyTap>* taps) {
  const int W = camera.width, H = camera.height;
  if (grad_rgb.width() != W || grad_rgb.height() != H || !sky_rgb.same_size(grad_rgb) || alpha.width() != W ||
      alpha.height() != H)
    fail("sky: gradient, sky and alpha images differ from the ", W, "x", H, " camera");
  if (grad_texels.size() != 3 * sky.texels()) fail("sky: texel gradient has ", grad_texels.size(), " values");
  if (taps && taps->size() != size_t(W) * size_t(H))
    fail("sky: ", taps->size(), " taps for a ", W, "x", H, " camera");
  if (grad_alpha.width() != W || grad_alpha.height() != H || grad_alpha.channels() != 1)
    grad_alpha = ImageF(W, H, 1);
  const int threads = omp_get_max_threads();
  std::vector<std::vector<float>> sums(static_cast<size_t>(threads));
#pragma omp parallel num_threads(threads)
  {
    // Texels are shared by many pixels (a scatter): each thread sums into its own copy.
    std::vector<float>& mine = sums[size_t(omp_get_thread_num())];
    mine.assign(grad_texels.size(), 0.f);
#pragma omp for schedule(static)
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const float clear = 1 - alpha(u, v);
        const float g[3] = {grad_rgb(u, v, 0), grad_rgb(u, v, 1), grad_rgb(u, v, 2)};
        if (!sky_pixel_usable(g, clear)) {
          grad_alpha(u, v) = 0;
          continue;
        }
        float ga = 0;
        for (int c = 0; c < 3; ++c) ga -= g[c] * sky_rgb(u, v, c);
        grad_alpha(u, v) = ga;
        if (clear <= 0 || (g[0] == 0 && g[1] == 0 && g[2] == 0)) continue;
        const SkyTap t = taps ? (*taps)[size_t(v) * size_t(W) + size_t(u)]
                              : sky_pixel_tap(sky.axes, sky.width, sky.height, camera, u, v);
        for (int k = 0; k < 4; ++k)
          for (int c = 0; c < 3; ++c) mine[3 * size_t(t.index[k]) + size_t(c)] += t.weight[k] * clear * g[c];
      }
  }
  for (const std::vector<float>& part : sums)
    for (size_t i = 0; i < part.size(); ++i) grad_texels[i] += part[i];
}

void sky_adam_step(SkyTexture& sky, const std::vector<float>& grad, double lr) {
  if (grad.size() != 3 * sky.texels()) fail("sky: texel gradient has ", grad.size(), " values");
  for (size_t i = 0; i < sky.texels(); ++i)
    sky_adam_texel(&sky.rgb[3 * i], &sky.m1[3 * i], &sky.m2[3 * i], sky.updates[i], &grad[3 * i], float(lr));
}

}  // namespace chungs
