#include "chungs/store/half_float.hpp"

#include <cmath>
#include <cstring>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define CHUNGS_HAVE_F16C_PATH 1
#endif

namespace chungs {

namespace {
uint32_t bits_of(float f) {
  uint32_t x;
  std::memcpy(&x, &f, 4);
  return x;
}
float float_of(uint32_t x) {
  float f;
  std::memcpy(&f, &x, 4);
  return f;
}
}  // namespace

uint16_t float_to_half(float f) {
  const uint32_t x = bits_of(f);
  const uint16_t sign = uint16_t((x >> 16) & 0x8000);
  const uint32_t a = x & 0x7fffffff;
  if (a >= 0x7f800000) return sign | (a > 0x7f800000 ? 0x7e00 : 0x7c00);  // NaN stays NaN
  if (a >= 0x47800000) return sign | 0x7c00;                              // >= 2^16: infinity
  if (a < 0x38800000) {
    // Below 2^-14 the half is subnormal: its integer mantissa is the value in units of 2^-24.
    // The product is exact (a power-of-two factor) and nearbyint rounds half to even.
    return sign | uint16_t(std::nearbyint(float_of(a) * 16777216.0f));
  }
  uint32_t h = ((a >> 23) - 112) << 10 | (a & 0x7fffff) >> 13;  // rebias 127 -> 15
  const uint32_t rest = a & 0x1fff;
  if (rest > 0x1000 || (rest == 0x1000 && (h & 1))) ++h;  // a carry rolls into the exponent
  return sign | uint16_t(h);
}

#ifdef CHUNGS_HAVE_F16C_PATH
namespace {
bool cpu_has_f16c() {
  static const bool yes = __builtin_cpu_supports("f16c") && __builtin_cpu_supports("avx");
  return yes;
}

__attribute__((target("avx,f16c"))) size_t f16c_to_halves(const float* in, uint16_t* out, size_t n) {
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m128i h = _mm256_cvtps_ph(_mm256_loadu_ps(in + i), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i), h);
  }
  return i;
}

__attribute__((target("avx,f16c"))) size_t f16c_to_floats(const uint16_t* in, float* out, size_t n) {
  size_t i = 0;
  for (; i + 8 <= n; i += 8)
    _mm256_storeu_ps(out + i, _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i))));
  return i;
}
}  // namespace
#endif

void floats_to_halves(const float* in, uint16_t* out, size_t n) {
  size_t i = 0;
#ifdef CHUNGS_HAVE_F16C_PATH
  if (cpu_has_f16c()) i = f16c_to_halves(in, out, n);
#endif
  for (; i < n; ++i) out[i] = float_to_half(in[i]);
}

void halves_to_floats(const uint16_t* in, float* out, size_t n) {
  size_t i = 0;
#ifdef CHUNGS_HAVE_F16C_PATH
  if (cpu_has_f16c()) i = f16c_to_floats(in, out, n);
#endif
  for (; i < n; ++i) out[i] = half_to_float(in[i]);
}

float half_to_float(uint16_t h) {
  const uint32_t sign = uint32_t(h & 0x8000) << 16;
  const uint32_t e = (h >> 10) & 0x1f, m = h & 0x3ff;
  if (e == 0) {
    const float v = float(m) * (1.0f / 16777216.0f);
    return sign ? -v : v;
  }
  if (e == 31) return float_of(sign | 0x7f800000 | m << 13);
  return float_of(sign | (e + 112) << 23 | m << 13);
}

}  // namespace chungs
