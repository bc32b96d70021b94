// Fixed-width SIMD lanes through the GCC/Clang vector extensions (16-byte vectors: SSE2 on x86-64,
// NEON on ARM), so the per-tile compositing runs 4 float (or 2 double) pixels at a time without
// depending on the auto-vectoriser or on target flags. Comparisons give lane masks (all bits set
// = true) and `mask ? a : b` selects per lane.
#pragma once
#include <bit>
#include <cmath>
#include <cstdint>
#include <type_traits>

namespace chungs::cpu {

template <typename T>
struct Lanes {
  using I = std::conditional_t<sizeof(T) == 4, int32_t, int64_t>;  // same width as T
  static constexpr int N = 16 / int(sizeof(T));
  typedef T V __attribute__((vector_size(16)));
  typedef I M __attribute__((vector_size(16)));

  static V splat(T v) { return V{} + v; }
  static M splat_i(I v) { return M{} + v; }
  static V iota() {  // 0, 1, ..., N - 1
    V r;
    for (int i = 0; i < N; ++i) r[i] = T(i);
    return r;
  }
  static V load(const T* p) { return *reinterpret_cast<const V*>(p); }  // p 16-byte aligned
  static void store(T* p, V v) { *reinterpret_cast<V*>(p) = v; }
  static M load_i(const I* p) { return *reinterpret_cast<const M*>(p); }
  static void store_i(I* p, M v) { *reinterpret_cast<M*>(p) = v; }
  static bool any(M m) {
    I r = 0;
    for (int i = 0; i < N; ++i) r |= m[i];
    return r != 0;
  }
  static T sum(V v) {
    T r = 0;
    for (int i = 0; i < N; ++i) r += v[i];
    return r;
  }
  static V min(V a, V b) { return a < b ? a : b; }
  static V max(V a, V b) { return a > b ? a : b; }

  // exp per lane. float: range reduction to 2^n e^y with |y| <= ln2/2 and a degree-7 Taylor
  // polynomial, relative error about one ulp for x in [-80, 0] (the range the rasterizer needs;
  // inputs below -80 are clamped). double: the library exp, lane by lane, so the float64 path that
  // the gradient tests use is exact to libm.
  static V exp(V x) {
    if constexpr (sizeof(T) == 4) {
      x = max(x, splat(-80.0f));
      const V t = x * 1.44269504088896341f;
      const V n = (t + 12582912.0f) - 12582912.0f;  // round to nearest (1.5 * 2^23 trick)
      const V y = (t - n) * 0.693147180559945309f;
      V p = splat(1.0f / 5040.0f);
      p = p * y + 1.0f / 720.0f;
      p = p * y + 1.0f / 120.0f;
      p = p * y + 1.0f / 24.0f;
      p = p * y + 1.0f / 6.0f;
      p = p * y + 0.5f;
      p = p * y + 1.0f;
      p = p * y + 1.0f;
      const M bits = (__builtin_convertvector(n, M) + 127) << 23;
      return p * std::bit_cast<V>(bits);
    } else {
      V r;
      for (int i = 0; i < N; ++i) r[i] = std::exp(x[i]);
      return r;
    }
  }
};

}  // namespace chungs::cpu
