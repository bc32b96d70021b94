#include "chungs/eval/image_metrics.hpp"

#include <cmath>
#include <limits>

namespace chungs {

namespace {

template <typename T>
void check_shapes(const Image<T>& a, const Image<T>& b, const Image8* mask, const char* what) {
  if (!a.same_shape(b))
    fail(what, ": images differ in shape: ", a.width(), "x", a.height(), "x", a.channels(), " vs ", b.width(), "x",
         b.height(), "x", b.channels());
  if (mask && (mask->channels() != 1 || !mask->same_size(a)))
    fail(what, ": mask must be 1 channel of ", a.width(), "x", a.height(), ", got ", mask->width(), "x",
         mask->height(), "x", mask->channels());
}

// Sum of squared differences and the number of kept pixels.
std::pair<double, size_t> squared_error(const ImageF& a, const ImageF& b, const Image8* mask) {
  const int w = a.width(), h = a.height(), nc = a.channels();
  double sum = 0.0;
  size_t kept = 0;
#pragma omp parallel for schedule(static) reduction(+ : sum, kept)
  for (int y = 0; y < h; ++y) {
    const float* ra = a.row(y);
    const float* rb = b.row(y);
    const uint8_t* m = mask ? mask->row(y) : nullptr;
    double rs = 0.0;
    for (int x = 0; x < w; ++x) {
      if (m && !m[x]) continue;
      for (int c = 0; c < nc; ++c) {
        const double d = double(ra[size_t(x) * nc + c]) - double(rb[size_t(x) * nc + c]);
        rs += d * d;
      }
      ++kept;
    }
    sum += rs;
  }
  return {sum, kept};
}

}  // namespace

double mse(const ImageF& a, const ImageF& b, const Image8* mask) {
  check_shapes(a, b, mask, "mse");
  auto [sum, kept] = squared_error(a, b, mask);
  return kept ? sum / (double(kept) * a.channels()) : std::numeric_limits<double>::quiet_NaN();
}

double psnr_from_mse(double m, double data_range) {
  if (m == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(data_range * data_range / m);
}

double psnr(const ImageF& a, const ImageF& b, const Image8* mask) { return psnr_from_mse(mse(a, b, mask)); }

double psnr(const Image8& a, const Image8& b, const Image8* mask) {
  check_shapes(a, b, mask, "psnr");
  return psnr(to_float(a), to_float(b), mask);
}

ImageMetrics compare_images(const ImageF& ref, const ImageF& test, const Image8* mask, const SsimOptions& ssim_opt) {
  check_shapes(ref, test, mask, "compare images");
  ImageMetrics m;
  auto [sum, kept] = squared_error(ref, test, mask);
  m.pixels = kept;
  m.mse = kept ? sum / (double(kept) * ref.channels()) : std::numeric_limits<double>::quiet_NaN();
  m.psnr = psnr_from_mse(m.mse);
  SsimOptions opt = ssim_opt;
  opt.want_map = false;
  m.ssim = ssim(ref, test, opt, mask).mean;
  return m;
}

ImageMetrics compare_images(const Image8& ref, const Image8& test, const Image8* mask, const SsimOptions& ssim_opt) {
  check_shapes(ref, test, mask, "compare images");
  return compare_images(to_float(ref), to_float(test), mask, ssim_opt);
}

}  // namespace chungs
