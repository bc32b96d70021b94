#include "chungs/eval/conv2d.hpp"

#include <Eigen/Core>
#include <algorithm>

#include "chungs/common/error.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define CHUNGS_CONV_AVX2 1
#endif

namespace chungs {

namespace {

using ColMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor>;

// im2col of a full 1241x376 conv1 would take 42 MB and grows with the image: output rows are
// unfolded a band at a time so the scratch stays near this many floats whatever the image size.
constexpr size_t kColumnBudget = size_t(8) << 20;

int out_size(int in, int kernel, int stride, int pad) {
  const int span = in + 2 * pad - kernel;
  return span < 0 ? 0 : span / stride + 1;
}

struct Geometry {
  int out, kernel, stride, pad, oh, ow, taps;
};

void conv_portable(const FeatureMap& in, const Geometry& g, const float* weight, FeatureMap& res) {
  // Pixels as rows, channels as columns: the map's CHW storage is then a column-major matrix, and
  // PyTorch's [out][in][ky][kx] weights are a column-major taps x out matrix as they lie.
  const Eigen::Map<const ColMatrix> wm(weight, g.taps, g.out);
  Eigen::Map<ColMatrix> om(res.data.data(), Eigen::Index(res.plane()), g.out);
  const int band = int(std::clamp<size_t>(kColumnBudget / (size_t(g.ow) * g.taps), 1, size_t(g.oh)));
  ColMatrix cols;
  for (int y0 = 0; y0 < g.oh; y0 += band) {
    const int rows = std::min(band, g.oh - y0);
    const Eigen::Index pixels = Eigen::Index(rows) * g.ow;
    cols.resize(pixels, g.taps);
#pragma omp parallel for schedule(static)
    for (int t = 0; t < g.taps; ++t) {
      const int c = t / (g.kernel * g.kernel), ky = (t / g.kernel) % g.kernel, kx = t % g.kernel;
      float* col = cols.data() + size_t(t) * pixels;
      for (int r = 0; r < rows; ++r) {
        const int iy = (y0 + r) * g.stride - g.pad + ky;
        float* dst = col + size_t(r) * g.ow;
        if (iy < 0 || iy >= in.height) {
          std::fill(dst, dst + g.ow, 0.f);
          continue;
        }
        const float* src = in.data.data() + c * in.plane() + size_t(iy) * in.width;
        for (int x = 0; x < g.ow; ++x) {
          const int ix = x * g.stride - g.pad + kx;
          dst[x] = (ix >= 0 && ix < in.width) ? src[ix] : 0.f;
        }
      }
    }
    om.middleRows(Eigen::Index(y0) * g.ow, pixels).noalias() = cols * wm;
  }
}

#ifdef CHUNGS_CONV_AVX2
// A 16-pixel by 6-channel block of the output takes 12 of the 16 vector registers as accumulators,
// leaving two for the pixels' taps and one for a weight broadcast.
constexpr int kMr = 16, kNr = 6;
// Taps per pass: a pixel panel's slice (16 KB) stays in L1 while every channel panel uses it.
constexpr int kKc = 256;

__attribute__((target("avx2,fma"))) void micro_kernel(int kc, const float* a, const float* b, float* c, bool first) {
  __m256 acc[kNr][2];
  for (int j = 0; j < kNr; ++j)
    for (int h = 0; h < 2; ++h) acc[j][h] = first ? _mm256_setzero_ps() : _mm256_loadu_ps(c + j * kMr + 8 * h);
  for (int k = 0; k < kc; ++k) {
    const __m256 a0 = _mm256_loadu_ps(a), a1 = _mm256_loadu_ps(a + 8);
    for (int j = 0; j < kNr; ++j) {
      const __m256 bj = _mm256_broadcast_ss(b + j);
      acc[j][0] = _mm256_fmadd_ps(a0, bj, acc[j][0]);
      acc[j][1] = _mm256_fmadd_ps(a1, bj, acc[j][1]);
    }
    a += kMr;
    b += kNr;
  }
  for (int j = 0; j < kNr; ++j)
    for (int h = 0; h < 2; ++h) _mm256_storeu_ps(c + j * kMr + 8 * h, acc[j][h]);
}

// The taps of 16 consecutive output pixels, [tap][pixel]. The pixels of a panel lie in one or a
// few runs along an output row; a run's taps are strided reads of one input row (contiguous at
// stride 1), checked against the image's edges only where the run reaches them.
void pack_panel(const FeatureMap& in, const Geometry& g, int y0, size_t first, size_t pixels, float* a) {
  struct Run {
    int m0, len, iy, ix;  // iy < 0 - kernel marks the zero padding after the last pixel
  };
  Run runs[kMr];
  int nruns = 0;
  for (int m = 0; m < kMr;) {
    const size_t p = first + m;
    if (p >= pixels) {
      runs[nruns++] = {m, kMr - m, -(1 << 28), 0};
      break;
    }
    const int x = int(p % g.ow), len = std::min(kMr - m, g.ow - x);
    runs[nruns++] = {m, len, (y0 + int(p / g.ow)) * g.stride - g.pad, x * g.stride - g.pad};
    m += len;
  }
  const int w = in.width, s = g.stride;
  for (int c = 0, t = 0; c < in.channels; ++c) {
    const float* plane = in.data.data() + c * in.plane();
    for (int ky = 0; ky < g.kernel; ++ky)
      for (int kx = 0; kx < g.kernel; ++kx, ++t) {
        float* dst = a + size_t(t) * kMr;
        for (int r = 0; r < nruns; ++r) {
          const Run& run = runs[r];
          float* d = dst + run.m0;
          const int iy = run.iy + ky, ix = run.ix + kx;
          if (iy < 0 || iy >= in.height) {
            std::fill(d, d + run.len, 0.f);
            continue;
          }
          const float* row = plane + size_t(iy) * w;
          if (ix >= 0 && ix + (run.len - 1) * s < w) {
            if (s == 1)
              std::copy(row + ix, row + ix + run.len, d);
            else
              for (int j = 0; j < run.len; ++j) d[j] = row[ix + j * s];
          } else {
            for (int j = 0; j < run.len; ++j) {
              const int xx = ix + j * s;
              d[j] = (xx >= 0 && xx < w) ? row[xx] : 0.f;
            }
          }
        }
      }
  }
}

// Taps unfolded straight into the kernel's order, [pixel panel][tap][16 pixels], and the weights
// into [channel panel][tap][6 channels], both zero-padded to whole panels, so the kernel reads
// memory in sequence.
void conv_avx2(const FeatureMap& in, const Geometry& g, const float* weight, FeatureMap& res) {
  const int npan = (g.out + kNr - 1) / kNr;
  std::vector<float> bp(size_t(npan) * g.taps * kNr, 0.f);
  for (int o = 0; o < g.out; ++o)
    for (int t = 0; t < g.taps; ++t) bp[(size_t(o / kNr) * g.taps + t) * kNr + o % kNr] = weight[size_t(o) * g.taps + t];

  const size_t plane = res.plane();
  const int band = int(std::clamp<size_t>(kColumnBudget / (size_t(g.ow) * g.taps), 1, size_t(g.oh)));
  std::vector<float> ap, cp;
  for (int y0 = 0; y0 < g.oh; y0 += band) {
    const int rows = std::min(band, g.oh - y0);
    const size_t pixels = size_t(rows) * g.ow, base = size_t(y0) * g.ow;
    const int mpan = int((pixels + kMr - 1) / kMr);
    ap.resize(size_t(mpan) * g.taps * kMr);
    cp.resize(size_t(mpan) * npan * kMr * kNr);
#pragma omp parallel for schedule(dynamic, 4)
    for (int i = 0; i < mpan; ++i) {
      float* a = ap.data() + size_t(i) * g.taps * kMr;
      pack_panel(in, g, y0, size_t(i) * kMr, pixels, a);
      float* c = cp.data() + size_t(i) * npan * kMr * kNr;
      for (int k0 = 0; k0 < g.taps; k0 += kKc) {
        const int kc = std::min(kKc, g.taps - k0);
        for (int j = 0; j < npan; ++j)
          micro_kernel(kc, a + size_t(k0) * kMr, bp.data() + (size_t(j) * g.taps + k0) * kNr, c + size_t(j) * kMr * kNr,
                       k0 == 0);
      }
    }
#pragma omp parallel for schedule(static)
    for (int o = 0; o < g.out; ++o) {
      float* dst = res.data.data() + size_t(o) * plane + base;
      const float* src = cp.data() + size_t(o / kNr) * kMr * kNr + size_t(o % kNr) * kMr;
      for (size_t p = 0; p < pixels; ++p) dst[p] = src[(p / kMr) * npan * kMr * kNr + p % kMr];
    }
  }
}
#endif

}  // namespace

bool conv2d_avx2_available() {
#ifdef CHUNGS_CONV_AVX2
  static const bool ok = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return ok;
#else
  return false;
#endif
}

FeatureMap conv2d(const FeatureMap& in, const float* weight, const float* bias, int out, int kernel, int stride,
                  int pad, ConvPath path) {
  const Geometry g{out, kernel, stride, pad, out_size(in.height, kernel, stride, pad),
                   out_size(in.width, kernel, stride, pad), in.channels * kernel * kernel};
  if (g.oh < 1 || g.ow < 1)
    fail("conv2d: ", in.width, "x", in.height, " input is smaller than its ", kernel, "x", kernel, " kernel");
  if (path == ConvPath::Avx2 && !conv2d_avx2_available()) fail("conv2d: this CPU has no AVX2 and FMA");
  FeatureMap res(out, g.oh, g.ow);
  const bool avx2 = path == ConvPath::Avx2 || (path == ConvPath::Auto && conv2d_avx2_available());
#ifdef CHUNGS_CONV_AVX2
  if (avx2)
    conv_avx2(in, g, weight, res);
  else
    conv_portable(in, g, weight, res);
#else
  (void)avx2;
  conv_portable(in, g, weight, res);
#endif
  const size_t plane = res.plane();
  for (int o = 0; o < out; ++o) {
    float* d = res.data.data() + size_t(o) * plane;
    for (size_t p = 0; p < plane; ++p) d[p] += bias[o];
  }
  return res;
}

}  // namespace chungs
