#include "chungs/image/ssim.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace chungs {

std::vector<double> gaussian_kernel_1d(int size, double sigma) {
  if (size < 1 || size % 2 == 0) fail("gaussian kernel: size must be odd and positive, got ", size);
  if (!(sigma > 0.0)) fail("gaussian kernel: sigma must be positive, got ", sigma);
  const int r = size / 2;
  std::vector<double> g(size);
  double sum = 0.0;
  for (int k = 0; k < size; ++k) {
    double d = k - r;
    g[k] = std::exp(-d * d / (2.0 * sigma * sigma));
    sum += g[k];
  }
  for (double& v : g) v /= sum;
  return g;
}

namespace {

// The row kernels carry most of the work; where the CPU has AVX2 + FMA they run 8 lanes wide.
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define CHUNGS_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define CHUNGS_SIMD_CLONES
#endif

// out[j] = sum_k g[k] src[j + k]. For the standard 11 taps the tap loop is unrolled at compile
// time so each output vector is summed in registers; other sizes go tap-outer with axpy rows.
template <int N>
CHUNGS_SIMD_CLONES void correlate_fixed(float* __restrict out, const float* __restrict src, const float* __restrict g,
                                        int wo) {
  float gk[N];
  for (int k = 0; k < N; ++k) gk[k] = g[k];
  for (int j = 0; j < wo; ++j) {
    float a = 0.f;
    for (int k = 0; k < N; ++k) a += gk[k] * src[j + k];
    out[j] = a;
  }
}

CHUNGS_SIMD_CLONES void axpy(float* __restrict out, const float* __restrict src, float a, int n) {
  for (int j = 0; j < n; ++j) out[j] += a * src[j];
}

void correlate_row(float* out, const float* src, const float* g, int n, int wo) {
  if (n == 11) return correlate_fixed<11>(out, src, g, wo);
  std::fill(out, out + wo, 0.f);
  for (int k = 0; k < n; ++k) axpy(out, src + k, g[k], wo);
}

// out[j] = sum_k g[k] rows[k][j]: the vertical counterpart over the rows of a window.
template <int N>
CHUNGS_SIMD_CLONES void column_fixed(float* __restrict out, const float* const* __restrict rows,
                                     const float* __restrict g, int wo) {
  float gk[N];
  const float* r[N];
  for (int k = 0; k < N; ++k) gk[k] = g[k], r[k] = rows[k];
  for (int j = 0; j < wo; ++j) {
    float a = 0.f;
    for (int k = 0; k < N; ++k) a += gk[k] * r[k][j];
    out[j] = a;
  }
}

void column_sum(float* out, const float* const* rows, const float* g, int n, int wo) {
  if (n == 11) return column_fixed<11>(out, rows, g, wo);
  std::fill(out, out + wo, 0.f);
  for (int k = 0; k < n; ++k) axpy(out, rows[k], g[k], wo);
}

// SSIM of one row from the window moments of the centred values.
CHUNGS_SIMD_CLONES void ssim_row(float* __restrict out, const float* __restrict mx, const float* __restrict my,
                                 const float* __restrict mxx, const float* __restrict myy,
                                 const float* __restrict mxy, float centre, float c1, float c2, int n) {
  for (int j = 0; j < n; ++j) {
    const float ax = mx[j], ay = my[j];
    const float vx = mxx[j] - ax * ax, vy = myy[j] - ay * ay, cxy = mxy[j] - ax * ay;
    const float ux = ax + centre, uy = ay + centre;
    out[j] = ((2.f * ux * uy + c1) * (2.f * cxy + c2)) / ((ux * ux + uy * uy + c1) * (vx + vy + c2));
  }
}

template <int NC>
void deinterleave(const float* __restrict src, float* const* dst, int w, float centre) {
  for (int c = 0; c < NC; ++c) {
    float* __restrict d = dst[c];
    for (int x = 0; x < w; ++x) d[x] = src[size_t(x) * NC + c] - centre;
  }
}

// Sum of n floats in double, in eight independent lanes (a single running sum is bound by the
// add latency; the lanes vectorise).
CHUNGS_SIMD_CLONES double sum_row(const float* __restrict v, const uint8_t* __restrict keep, int n) {
  double lane[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int j = 0;
  for (; j + 8 <= n; j += 8)
    for (int k = 0; k < 8; ++k) lane[k] += keep ? (keep[j + k] ? double(v[j + k]) : 0.0) : double(v[j + k]);
  for (; j < n; ++j) lane[0] += (!keep || keep[j]) ? double(v[j]) : 0.0;
  return ((lane[0] + lane[1]) + (lane[2] + lane[3])) + ((lane[4] + lane[5]) + (lane[6] + lane[7]));
}

// One thread's share: a band of output rows. The horizontally filtered moments of the last `n`
// padded rows live in a ring per channel (5 x n rows of wo floats, ~270 KB per channel for a
// 1241-wide image), so nothing image-sized is allocated and the vertical pass reads from cache;
// each input row is read once for all channels.
// Inputs are shifted by -L/2 on the way in: the moments are shift-invariant and centring keeps
// E[x^2] - mu^2 from cancelling in float. Zero padding in image space is -L/2 in shifted space.
class Band {
 public:
  Band(const ImageF& a, const ImageF& b, const std::vector<float>& g, int pad, int wo, float centre)
      : a_(a), b_(b), g_(g), nc_(a.channels()), n_(int(g.size())), pad_(pad), pw_(a.width() + 2 * pad), wo_(wo),
        centre_(centre), xy_(size_t(2) * nc_ * pw_), prod_(size_t(3) * pw_), ring_(size_t(nc_) * 5 * n_ * wo),
        m_(size_t(5) * wo) {}

  // SSIM of output rows [i0, i1), all channels: out[((i - i0) * nc + c) * wo + j].
  void run(int i0, int i1, float* out, float c1, float c2) {
    for (int k = 0; k < n_ - 1; ++k) filter_row(i0 + k);
    std::vector<const float*> rows(n_);
    for (int i = i0; i < i1; ++i) {
      filter_row(i + n_ - 1);
      for (int c = 0; c < nc_; ++c) {
        for (int q = 0; q < 5; ++q) {
          for (int k = 0; k < n_; ++k) rows[k] = slot(c, q, i + k);
          column_sum(m_.data() + size_t(q) * wo_, rows.data(), g_.data(), n_, wo_);
        }
        const float* m = m_.data();
        ssim_row(out + (size_t(i - i0) * nc_ + c) * wo_, m, m + wo_, m + 2 * wo_, m + 3 * wo_, m + 4 * wo_, centre_,
                 c1, c2, wo_);
      }
    }
  }

 private:
  float* slot(int c, int q, int padded_row) {
    return ring_.data() + ((size_t(c) * 5 + q) * n_ + padded_row % n_) * wo_;
  }
  float* plane_x(int c) { return xy_.data() + size_t(c) * pw_; }
  float* plane_y(int c) { return xy_.data() + size_t(nc_ + c) * pw_; }

  void filter_row(int padded_row) {
    const int sy = padded_row - pad_, w = a_.width();
    std::fill(xy_.begin(), xy_.end(), -centre_);
    if (sy >= 0 && sy < a_.height()) {
      float* dx[4];
      float* dy[4];
      for (int c = 0; c < nc_; ++c) dx[c] = plane_x(c) + pad_, dy[c] = plane_y(c) + pad_;
      // A compile-time stride lets the de-interleave vectorise.
      switch (nc_) {
        case 1: deinterleave<1>(a_.row(sy), dx, w, centre_), deinterleave<1>(b_.row(sy), dy, w, centre_); break;
        case 2: deinterleave<2>(a_.row(sy), dx, w, centre_), deinterleave<2>(b_.row(sy), dy, w, centre_); break;
        case 3: deinterleave<3>(a_.row(sy), dx, w, centre_), deinterleave<3>(b_.row(sy), dy, w, centre_); break;
        default: deinterleave<4>(a_.row(sy), dx, w, centre_), deinterleave<4>(b_.row(sy), dy, w, centre_); break;
      }
    }
    for (int c = 0; c < nc_; ++c) {
      const float *__restrict px = plane_x(c), *__restrict py = plane_y(c);
      float *__restrict pxx = prod_.data(), *__restrict pyy = pxx + pw_, *__restrict pxy = pyy + pw_;
      for (int i = 0; i < pw_; ++i) {
        pxx[i] = px[i] * px[i];
        pyy[i] = py[i] * py[i];
        pxy[i] = px[i] * py[i];
      }
      const float* src[5] = {px, py, pxx, pyy, pxy};
      for (int q = 0; q < 5; ++q) correlate_row(slot(c, q, padded_row), src[q], g_.data(), n_, wo_);
    }
  }

  const ImageF &a_, &b_;
  const std::vector<float>& g_;
  const int nc_, n_, pad_, pw_, wo_;
  const float centre_;
  std::vector<float> xy_, prod_, ring_, m_;
};

}  // namespace

SsimResult ssim(const ImageF& a, const ImageF& b, const SsimOptions& opt, const Image8* mask) {
  if (!a.same_shape(b))
    fail("ssim: images differ in shape: ", a.width(), "x", a.height(), "x", a.channels(), " vs ", b.width(), "x",
         b.height(), "x", b.channels());
  if (a.empty()) fail("ssim: empty image");
  if (mask && (mask->channels() != 1 || !mask->same_size(a)))
    fail("ssim: mask must be 1 channel of ", a.width(), "x", a.height(), ", got ", mask->width(), "x",
         mask->height(), "x", mask->channels());
  if (!(opt.data_range > 0.0)) fail("ssim: data range must be positive, got ", opt.data_range);
  const std::vector<double> g64 = gaussian_kernel_1d(opt.window, opt.sigma);
  const std::vector<float> g(g64.begin(), g64.end());
  const int r = opt.window / 2;
  const int pad = opt.border == SsimBorder::ZeroPad ? r : 0;
  const int wo = a.width() + 2 * pad - 2 * r, ho = a.height() + 2 * pad - 2 * r;
  if (wo < 1 || ho < 1)
    fail("ssim: image ", a.width(), "x", a.height(), " is smaller than the ", opt.window, "x", opt.window,
         " window (valid border)");

  SsimResult res;
  res.offset = r - pad;
  if (opt.want_map) res.map = ImageF(wo, ho, a.channels());
  const float centre = float(0.5 * opt.data_range);
  const float c1 = float(std::pow(0.01 * opt.data_range, 2)), c2 = float(std::pow(0.03 * opt.data_range, 2));
  const int nc = a.channels();

  double sum = 0.0;
  size_t counted = 0;
  // Bands of at least 32 rows, so that the n - 1 rows each band filters twice stay a small share.
  const int max_threads = std::max(1, std::min(omp_get_max_threads(), ho / 32));
#pragma omp parallel num_threads(max_threads) reduction(+ : sum, counted)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    const int i0 = int(int64_t(ho) * t / nt), i1 = int(int64_t(ho) * (t + 1) / nt);
    if (i1 > i0) {
      Band band(a, b, g, pad, wo, centre);
      std::vector<float> vals(size_t(i1 - i0) * nc * wo);
      band.run(i0, i1, vals.data(), c1, c2);
      for (int i = i0; i < i1; ++i) {
        const uint8_t* keep = mask ? mask->row(i + res.offset) + res.offset : nullptr;
        counted += keep ? size_t(std::count_if(keep, keep + wo, [](uint8_t m) { return m != 0; })) : size_t(wo);
        for (int c = 0; c < nc; ++c) {
          const float* v = vals.data() + (size_t(i - i0) * nc + c) * wo;
          if (opt.want_map) {
            float* out = res.map.row(i);
            for (int j = 0; j < wo; ++j) out[size_t(j) * nc + c] = v[j];
          }
          sum += sum_row(v, keep, wo);
        }
      }
    }
  }
  res.counted = counted;
  res.mean = counted ? sum / (double(counted) * nc) : std::numeric_limits<double>::quiet_NaN();
  return res;
}

}  // namespace chungs
