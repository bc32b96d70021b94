// Procedural texture primitives with built-in anti-aliasing. Every function that draws detail takes
// the pixel footprint on the surface (metres per pixel) and removes detail the pixel cannot resolve,
// replacing it by its mean: frames stay stable under motion instead of flickering like pure noise.
#pragma once
#include <cmath>
#include <cstdint>

namespace chungs::synth {

// Integer lattice hash -> [0, 1).
inline float hash01(int64_t x, int64_t y, uint32_t seed) {
  uint64_t h = uint64_t(x) * 0x9e3779b97f4a7c15ULL ^ (uint64_t(y) * 0xc2b2ae3d27d4eb4fULL + seed);
  h ^= h >> 29;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 32;
  return float(h >> 40) * 0x1.0p-24f;
}

// 2D value noise in [-1, 1], smooth (C1) between integer lattice points. Coordinates are doubles so
// that a 10 km world keeps centimetre detail.
float value_noise(double x, double y, uint32_t seed);

// Weight of detail with period `period` (metres) at footprint `fp`: 1 when the period spans >= 2
// pixels, 0 at <= 1 pixel, linear between.
inline float detail_weight(double period, double fp) {
  double ppp = period / fp;
  return ppp >= 2 ? 1.f : ppp <= 1 ? 0.f : float(ppp - 1);
}

// Fractal sum of `octaves` value-noise octaves, the first with period `period` (metres), each next
// one half the period and `gain` the amplitude. Octaves finer than the footprint fade out. Result is
// roughly in [-1, 1] (normalised by the total amplitude of all octaves).
float fbm(double x, double y, double period, int octaves, uint32_t seed, double fp, float gain = 0.5f);

// fbm for grazing views (roads seen from a car): footprints fs along x and ft along y may differ
// by several times. Each octave is averaged over up to 4 samples along the longer footprint, so
// detail across the view survives that a single isotropic footprint would blur away; anisotropy
// beyond 4:1 is filtered as if the short footprint were a quarter of the long one.
float fbm_aniso(double x, double y, double period, int octaves, uint32_t seed, double fs, double ft,
                float gain = 0.5f);

// Fraction of the box filter [x - fp/2, x + fp/2] covered by the pulse train that is "on" on
// [k*period + a, k*period + b] for all integers k (0 <= a < b <= period). Exact box filtering.
float pulse_train(double x, double period, double a, double b, double fp);

// Fraction of [x - fp/2, x + fp/2] inside [a, b].
inline float box_coverage(double x, double a, double b, double fp) {
  double lo = x - 0.5 * fp, hi = x + 0.5 * fp;
  double inside = std::fmin(hi, b) - std::fmax(lo, a);
  return inside <= 0 ? 0.f : float(inside / fp);
}

// Lines of width w centred on multiples of `period`.
inline float line_train(double x, double period, double w, double fp) {
  return pulse_train(x + 0.5 * w, period, 0, w, fp);
}

inline float clamp01(float v) { return v < 0 ? 0.f : v > 1 ? 1.f : v; }
inline float smoothstep(float e0, float e1, float x) {
  float t = clamp01((x - e0) / (e1 - e0));
  return t * t * (3 - 2 * t);
}

}  // namespace chungs::synth
