#include "chungs/synth/noise.hpp"

#include <algorithm>

namespace chungs::synth {

float value_noise(double x, double y, uint32_t seed) {
  double fx = std::floor(x), fy = std::floor(y);
  int64_t ix = int64_t(fx), iy = int64_t(fy);
  float tx = float(x - fx), ty = float(y - fy);
  // Quintic fade: C2 continuity avoids visible creases along lattice lines in shaded gradients.
  tx = tx * tx * tx * (tx * (tx * 6 - 15) + 10);
  ty = ty * ty * ty * (ty * (ty * 6 - 15) + 10);
  float v00 = hash01(ix, iy, seed), v10 = hash01(ix + 1, iy, seed);
  float v01 = hash01(ix, iy + 1, seed), v11 = hash01(ix + 1, iy + 1, seed);
  float a = v00 + (v10 - v00) * tx, b = v01 + (v11 - v01) * tx;
  return 2 * (a + (b - a) * ty) - 1;
}

float fbm(double x, double y, double period, int octaves, uint32_t seed, double fp, float gain) {
  float sum = 0, norm = 0, amp = 1;
  double freq = 1 / period;
  for (int o = 0; o < octaves; ++o) {
    norm += amp;
    float w = detail_weight(1 / freq, fp);
    if (w <= 0) {
      // Remaining octaves are finer still: they only add to the normaliser.
      for (int r = o + 1; r < octaves; ++r) norm += amp *= gain;
      break;
    }
    // Offsetting each octave decorrelates the lattices (no shared zero crossings at the origin).
    sum += w * amp * value_noise(x * freq + 17.3 * o, y * freq - 9.1 * o, seed + 101u * uint32_t(o));
    amp *= gain;
    freq *= 2;
  }
  return sum / norm;
}

float fbm_aniso(double x, double y, double period, int octaves, uint32_t seed, double fs, double ft, float gain) {
  const double fmax = std::max(fs, ft), feff = std::max(std::min(fs, ft), 0.25 * fmax);
  const bool long_x = fs >= ft;
  float sum = 0, norm = 0, amp = 1;
  double freq = 1 / period;
  for (int o = 0; o < octaves; ++o, amp *= gain, freq *= 2) {
    norm += amp;
    const float w = detail_weight(1 / freq, feff);
    if (w <= 0) continue;
    const double ox = 17.3 * o, oy = -9.1 * o;
    const uint32_t s = seed + 101u * uint32_t(o);
    // Stratified samples across the long footprint, about two per period.
    const int n = std::clamp(int(std::ceil(2 * fmax * freq)), 1, 4);
    float v = 0;
    for (int k = 0; k < n; ++k) {
      const double d = n == 1 ? 0 : ((k + 0.5) / n - 0.5) * fmax;
      v += value_noise((x + (long_x ? d : 0)) * freq + ox, (y + (long_x ? 0 : d)) * freq + oy, s);
    }
    sum += w * amp * v / float(n);
  }
  return sum / norm;
}

float pulse_train(double x, double period, double a, double b, double fp) {
  auto cumulative = [&](double v) {  // measure of the "on" set within [0, v] (extended to all v)
    double n = std::floor(v / period);
    double r = v - n * period;
    return n * (b - a) + std::clamp(r - a, 0.0, b - a);
  };
  if (fp <= 1e-9) {
    double r = x - std::floor(x / period) * period;
    return (r >= a && r < b) ? 1.f : 0.f;
  }
  double c = (cumulative(x + 0.5 * fp) - cumulative(x - 0.5 * fp)) / fp;
  return float(std::clamp(c, 0.0, 1.0));
}

}  // namespace chungs::synth
