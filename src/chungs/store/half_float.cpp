#include "chungs/store/half_float.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
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
  // Clang 14 does not know "f16c" in __builtin_cpu_supports, so that bit is asked of CPUID itself;
  // "avx" also covers the OS saving the AVX registers.
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  static const bool yes = __builtin_cpu_supports("avx") && __get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_F16C);
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

__attribute__((target("avx,f16c"))) size_t f16c_scaled_to_halves(const float* in, float factor, uint8_t* out,
                                                                 size_t n) {
  const __m256 f = _mm256_set1_ps(factor);
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_mul_ps(_mm256_loadu_ps(in + i), f);
    const __m128i h = _mm256_cvtps_ph(x, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 2 * i), h);
  }
  return i;
}

__attribute__((target("avx,f16c"))) size_t f16c_to_scaled_floats(const uint8_t* in, float factor, float* out,
                                                                 size_t n) {
  const __m256 f = _mm256_set1_ps(factor);
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in + 2 * i)));
    _mm256_storeu_ps(out + i, _mm256_mul_ps(x, f));
  }
  return i;
}

__attribute__((target("avx"))) size_t avx_max_finite_abs(const float* v, size_t n, float& largest) {
  const __m256 sign = _mm256_set1_ps(-0.0f), inf = _mm256_set1_ps(INFINITY);
  __m256 m = _mm256_setzero_ps();
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 a = _mm256_andnot_ps(sign, _mm256_loadu_ps(v + i));
    const __m256 finite = _mm256_cmp_ps(a, inf, _CMP_LT_OQ);  // false for NaN and infinity
    m = _mm256_max_ps(m, _mm256_and_ps(a, finite));
  }
  alignas(32) float lanes[8];
  _mm256_store_ps(lanes, m);
  for (float x : lanes) largest = std::max(largest, x);
  return i;
}

__attribute__((target("avx"))) size_t avx_signed_sqrt(const float* in, float* out, size_t n) {
  const __m256 sign = _mm256_set1_ps(-0.0f);
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_loadu_ps(in + i);
    const __m256 r = _mm256_sqrt_ps(_mm256_andnot_ps(sign, x));
    _mm256_storeu_ps(out + i, _mm256_or_ps(r, _mm256_and_ps(sign, x)));
  }
  return i;
}

// Finds blocks of 8 with a zero half from a non-zero source; the caller fixes those lanes.
__attribute__((target("avx"))) bool avx_any_lost(const float* source, const uint8_t* halves) {
  const __m128i h = _mm_loadu_si128(reinterpret_cast<const __m128i*>(halves));
  const __m128i zero_h = _mm_cmpeq_epi16(_mm_and_si128(h, _mm_set1_epi16(0x7fff)), _mm_setzero_si128());
  const __m256 nonzero = _mm256_cmp_ps(_mm256_loadu_ps(source), _mm256_setzero_ps(), _CMP_NEQ_UQ);
  const __m128i nz = _mm_packs_epi32(_mm_castps_si128(_mm256_castps256_ps128(nonzero)),
                                     _mm_castps_si128(_mm256_extractf128_ps(nonzero, 1)));
  return _mm_movemask_epi8(_mm_and_si128(zero_h, nz)) != 0;
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

void scaled_floats_to_halves(const float* in, float factor, uint8_t* out, size_t n) {
  size_t i = 0;
#ifdef CHUNGS_HAVE_F16C_PATH
  if (cpu_has_f16c()) i = f16c_scaled_to_halves(in, factor, out, n);
#endif
  for (; i < n; ++i) {
    const uint16_t h = float_to_half(in[i] * factor);
    std::memcpy(out + 2 * i, &h, 2);
  }
}

void halves_to_scaled_floats(const uint8_t* in, float factor, float* out, size_t n) {
  size_t i = 0;
#ifdef CHUNGS_HAVE_F16C_PATH
  if (cpu_has_f16c()) i = f16c_to_scaled_floats(in, factor, out, n);
#endif
  for (; i < n; ++i) {
    uint16_t h;
    std::memcpy(&h, in + 2 * i, 2);
    out[i] = half_to_float(h) * factor;
  }
}

void signed_sqrt(const float* in, float* out, size_t n) {
  size_t i = 0;
#ifdef CHUNGS_HAVE_F16C_PATH
  if (cpu_has_f16c()) i = avx_signed_sqrt(in, out, n);
#endif
  for (; i < n; ++i) out[i] = std::copysign(std::sqrt(std::fabs(in[i])), in[i]);
}

void keep_nonzero(const float* source, uint8_t* halves, size_t n) {
  auto fix = [&](size_t i) {
    if (source[i] == 0) return;
    uint16_t h;
    std::memcpy(&h, halves + 2 * i, 2);
    if ((h & 0x7fff) != 0) return;
    h = uint16_t((h & 0x8000) | 1);
    std::memcpy(halves + 2 * i, &h, 2);
  };
  size_t i = 0;
#ifdef CHUNGS_HAVE_F16C_PATH
  if (cpu_has_f16c())
    for (; i + 8 <= n; i += 8)
      if (avx_any_lost(source + i, halves + 2 * i))
        for (size_t k = i; k < i + 8; ++k) fix(k);
#endif
  for (; i < n; ++i) fix(i);
}

float max_finite_abs(const float* v, size_t n) {
  float largest = 0;
  size_t i = 0;
#ifdef CHUNGS_HAVE_F16C_PATH
  if (cpu_has_f16c()) i = avx_max_finite_abs(v, n, largest);
#endif
  for (; i < n; ++i) {
    const float a = std::fabs(v[i]);
    if (a > largest && a <= std::numeric_limits<float>::max()) largest = a;
  }
  return largest;
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
