#include "chungs/optim/loss_ssim.hpp"

#include <cmath>
#include <vector>

#include "chungs/common/ordered_sum.hpp"
#include "chungs/optim/loss_check.hpp"

namespace chungs {

namespace {

constexpr int kRadius = 5;  // 11 taps
constexpr double kSigma = 1.5;
constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;

template <typename T>
struct Window {
  T w[2 * kRadius + 1];
  Window() {
    double sum = 0, v[2 * kRadius + 1];
    for (int i = -kRadius; i <= kRadius; ++i)
      sum += v[i + kRadius] = std::exp(-0.5 * i * i / (kSigma * kSigma));
    for (int i = 0; i <= 2 * kRadius; ++i) w[i] = T(v[i] / sum);
  }
};

// Zero-padded separable Gaussian blur of `count` planes of W x H stored one after another. The kernel
// is symmetric, so this operator is its own adjoint (used as such in the backward).
template <typename T>
void blur_planes(const std::vector<T>& in, std::vector<T>& out, std::vector<T>& tmp, int W, int H,
                 int count) {
  static const Window<T> win;
  const size_t plane = size_t(W) * H;
  out.resize(in.size());
  tmp.resize(in.size());
#pragma omp parallel for schedule(static)
  for (long long r = 0; r < (long long)count * H; ++r) {
    const T* src = in.data() + size_t(r) * W;
    T* dst = tmp.data() + size_t(r) * W;
    // Pixels whose window meets the border sum the taps that lie inside; the interior, taps outer and
    // pixels inner so that the compiler vectorises across pixels (each pixel still adds its taps from
    // the first to the last, so the sums are the same to the bit).
    const int x0 = std::min(kRadius, W), x1 = std::max(x0, W - kRadius);
    const auto edge = [&](int x) {
      T s = 0;
      const int a = std::max(-kRadius, -x), b = std::min(kRadius, W - 1 - x);
      for (int i = a; i <= b; ++i) s += win.w[i + kRadius] * src[x + i];
      dst[x] = s;
    };
    for (int x = 0; x < x0; ++x) edge(x);
    for (int x = x1; x < W; ++x) edge(x);
    for (int x = x0; x < x1; ++x) dst[x] = 0;
    for (int i = -kRadius; i <= kRadius; ++i) {
      const T wi = win.w[i + kRadius];
      const T* s = src + i;
      for (int x = x0; x < x1; ++x) dst[x] += wi * s[x];
    }
  }
#pragma omp parallel for schedule(static)
  for (long long r = 0; r < (long long)count * H; ++r) {
    const size_t p = size_t(r) / H;
    const int y = int(size_t(r) % H);
    const T* base = tmp.data() + p * plane;
    T* dst = out.data() + p * plane + size_t(y) * W;
    for (int x = 0; x < W; ++x) dst[x] = 0;
    const int a = std::max(-kRadius, -y), b = std::min(kRadius, H - 1 - y);
    for (int i = a; i <= b; ++i) {
      const T wi = win.w[i + kRadius];
      const T* row = base + size_t(y + i) * W;
      for (int x = 0; x < W; ++x) dst[x] += wi * row[x];
    }
  }
}

}  // namespace

template <typename T>
double ssim_loss_term(const Image<T>& pred, const Image<T>& target, Image<T>* grad, double weight) {
  require_same_shape(pred, target, "SSIM loss: target");
  if (grad) require_same_shape(pred, *grad, "SSIM loss: gradient");
  const int W = pred.width(), H = pred.height(), C = pred.channels();
  const size_t plane = size_t(W) * H, n = plane * C;
  if (n == 0) return 1.0;

  // Scratch planes kept from one call to the next on each thread: allocated afresh at every step they
  // were page-faulted in again each time (a third of a CPU mapping run's time went to the kernel).
  // (References, so that the parallel loops below see this thread's planes, not their own.)
  struct Scratch {
    std::vector<T> in, mom, tmp, g, bg;
  };
  thread_local Scratch scratch;
  auto &in = scratch.in, &mom = scratch.mom, &tmp = scratch.tmp, &g = scratch.g, &bg = scratch.bg;
  // Five planes per channel: x, y, x^2, y^2, xy (planar, channel-major), blurred into the moments.
  in.resize(5 * n);
  for (int c = 0; c < C; ++c)
    for (size_t i = 0; i < plane; ++i) {
      const T x = pred.data()[i * C + c], y = target.data()[i * C + c];
      const size_t o = size_t(c) * plane + i;
      in[o] = x, in[n + o] = y, in[2 * n + o] = x * x, in[3 * n + o] = y * y, in[4 * n + o] = x * y;
    }
  blur_planes(in, mom, tmp, W, H, 5 * C);

  // SSIM map and, for the backward, dS/d(mu_x), dS/d(E[x^2]), dS/d(E[xy]) scaled by weight / n.
  if (grad) g.assign(3 * n, T(0));
  const T up = T(weight / double(n));
  const double sum = ordered_sum<double>((long long)n, [&](long long ii, double& acc) {
    const size_t i = size_t(ii);
    const T mx = mom[i], my = mom[n + i], exx = mom[2 * n + i], eyy = mom[3 * n + i], exy = mom[4 * n + i];
    const T A1 = 2 * mx * my + T(kC1), A2 = 2 * (exy - mx * my) + T(kC2);
    const T B1 = mx * mx + my * my + T(kC1), B2 = (exx - mx * mx) + (eyy - my * my) + T(kC2);
    const T S = A1 * A2 / (B1 * B2);
    acc += double(S);
    if (grad) {
      g[i] = up * S * (2 * my / A1 - 2 * my / A2 - 2 * mx / B1 + 2 * mx / B2);
      g[n + i] = up * (-S / B2);
      g[2 * n + i] = up * (2 * S / A2);
    }
  });
  if (grad) {
    blur_planes(g, bg, tmp, W, H, 3 * C);
    for (int c = 0; c < C; ++c)
      for (size_t i = 0; i < plane; ++i) {
        const size_t o = size_t(c) * plane + i;
        const T x = pred.data()[i * C + c], y = target.data()[i * C + c];
        grad->data()[i * C + c] += bg[o] + 2 * x * bg[n + o] + y * bg[2 * n + o];
      }
  }
  return sum / double(n);
}

template double ssim_loss_term<float>(const Image<float>&, const Image<float>&, Image<float>*, double);
template double ssim_loss_term<double>(const Image<double>&, const Image<double>&, Image<double>*, double);

}  // namespace chungs
