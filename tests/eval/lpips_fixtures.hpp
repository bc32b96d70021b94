// Random LPIPS weights for tests (no published weights can be fetched here): conv weights drawn as
// PyTorch initialises them (uniform within 1/sqrt(fan in)), heads uniform in [0, 1) as the
// published ones are non-negative; and a plain float64 LPIPS to check the fast one against.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "chungs/eval/lpips_weights.hpp"
#include "chungs/image/image.hpp"

namespace chungs::test {

inline LpipsWeights random_lpips_weights(uint32_t seed) {
  std::mt19937 rng(seed);
  LpipsWeights w;
  for (size_t l = 0; l < kAlexConv.size(); ++l) {
    const AlexConvShape& s = kAlexConv[l];
    const float bound = 1.f / std::sqrt(float(s.in * s.kernel * s.kernel));
    std::uniform_real_distribution<float> u(-bound, bound);
    w.conv[l].weight.resize(size_t(s.out) * s.in * s.kernel * s.kernel);
    for (float& v : w.conv[l].weight) v = u(rng);
    w.conv[l].bias.resize(size_t(s.out));
    for (float& v : w.conv[l].bias) v = u(rng);
    std::uniform_real_distribution<float> head(0.f, 1.f);
    w.lin[l].resize(size_t(s.out));
    for (float& v : w.lin[l]) v = head(rng);
  }
  return w;
}

inline ImageF random_image(int w, int h, int c, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.f, 1.f);
  ImageF img(w, h, c);
  for (float& v : img.vec()) v = u(rng);
  return img;
}

inline ImageF with_noise(const ImageF& img, float sigma, std::mt19937& rng) {
  std::normal_distribution<float> n(0.f, sigma);
  ImageF out = img;
  for (float& v : out.vec()) v = std::clamp(v + n(rng), 0.f, 1.f);
  return out;
}

// Float64 tensors, CHW, computed loop by loop from the definitions.
struct Tensor64 {
  int c = 0, h = 0, w = 0;
  std::vector<double> v;
  Tensor64(int c_, int h_, int w_) : c(c_), h(h_), w(w_), v(size_t(c_) * h_ * w_, 0.0) {}
  double& at(int ch, int y, int x) { return v[(size_t(ch) * h + y) * w + x]; }
  double at(int ch, int y, int x) const { return v[(size_t(ch) * h + y) * w + x]; }
};

inline Tensor64 conv64(const Tensor64& in, const std::vector<float>& wt, const std::vector<float>& b, int out, int k,
                       int stride, int pad) {
  const int oh = (in.h + 2 * pad - k) / stride + 1, ow = (in.w + 2 * pad - k) / stride + 1;
  Tensor64 r(out, oh, ow);
  for (int o = 0; o < out; ++o)
    for (int y = 0; y < oh; ++y)
      for (int x = 0; x < ow; ++x) {
        double s = b[size_t(o)];
        for (int c = 0; c < in.c; ++c)
          for (int ky = 0; ky < k; ++ky)
            for (int kx = 0; kx < k; ++kx) {
              const int iy = y * stride - pad + ky, ix = x * stride - pad + kx;
              if (iy < 0 || iy >= in.h || ix < 0 || ix >= in.w) continue;
              s += double(wt[((size_t(o) * in.c + c) * k + ky) * k + kx]) * in.at(c, iy, ix);
            }
        r.at(o, y, x) = s;
      }
  return r;
}

inline Tensor64 pool64(const Tensor64& in) {
  Tensor64 r(in.c, (in.h - 3) / 2 + 1, (in.w - 3) / 2 + 1);
  for (int c = 0; c < in.c; ++c)
    for (int y = 0; y < r.h; ++y)
      for (int x = 0; x < r.w; ++x) {
        double m = -INFINITY;
        for (int dy = 0; dy < 3; ++dy)
          for (int dx = 0; dx < 3; ++dx) m = std::max(m, in.at(c, 2 * y + dy, 2 * x + dx));
        r.at(c, y, x) = m;
      }
  return r;
}

inline Tensor64 normalize64(const Tensor64& in) {
  Tensor64 r = in;
  for (int y = 0; y < in.h; ++y)
    for (int x = 0; x < in.w; ++x) {
      double s = 0;
      for (int c = 0; c < in.c; ++c) s += in.at(c, y, x) * in.at(c, y, x);
      for (int c = 0; c < in.c; ++c) r.at(c, y, x) = in.at(c, y, x) / (std::sqrt(s) + 1e-10);
    }
  return r;
}

inline std::array<Tensor64, 5> features64(const LpipsWeights& w, const ImageF& img) {
  const double shift[3] = {-0.030, -0.088, -0.188}, scale[3] = {0.458, 0.448, 0.450};
  Tensor64 x(3, img.height(), img.width());
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < x.h; ++y)
      for (int xx = 0; xx < x.w; ++xx) x.at(c, y, xx) = (2.0 * img(xx, y, c) - 1.0 - shift[c]) / scale[c];
  std::vector<Tensor64> outs;
  for (size_t l = 0; l < kAlexConv.size(); ++l) {
    const AlexConvShape& s = kAlexConv[l];
    Tensor64 y = conv64(x, w.conv[l].weight, w.conv[l].bias, s.out, s.kernel, s.stride, s.pad);
    for (double& v : y.v) v = std::max(v, 0.0);
    outs.push_back(y);
    x = l < 2 ? pool64(y) : y;
  }
  return {outs[0], outs[1], outs[2], outs[3], outs[4]};
}

inline double lpips64(const LpipsWeights& w, const ImageF& a, const ImageF& b) {
  const auto fa = features64(w, a), fb = features64(w, b);
  double total = 0;
  for (size_t l = 0; l < 5; ++l) {
    const Tensor64 na = normalize64(fa[l]), nb = normalize64(fb[l]);
    double s = 0;
    for (int c = 0; c < na.c; ++c)
      for (int y = 0; y < na.h; ++y)
        for (int x = 0; x < na.w; ++x) {
          const double d = na.at(c, y, x) - nb.at(c, y, x);
          s += double(w.lin[l][size_t(c)]) * d * d;
        }
    total += s / (double(na.h) * na.w);
  }
  return total;
}

}  // namespace chungs::test
