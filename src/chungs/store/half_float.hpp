// IEEE 754 binary16 conversions (round to nearest, ties to even; subnormals, infinities and NaN
// kept), for storing optimiser state at half the size.
#pragma once
#include <cstddef>
#include <cstdint>

namespace chungs {

uint16_t float_to_half(float f);
float half_to_float(uint16_t h);
// The same conversions over arrays, with the CPU's F16C instructions where it has them (the
// results are identical, NaN payloads aside: a NaN stays a NaN).
void floats_to_halves(const float* in, uint16_t* out, size_t n);
void halves_to_floats(const uint16_t* in, float* out, size_t n);
// Fused forms for the chunk codec. out/in are byte buffers holding little-endian halves at any
// 2-byte offset: out gets float_to_half(in[i] * factor), the reverse gives half_to_float * factor.
void scaled_floats_to_halves(const float* in, float factor, uint8_t* out, size_t n);
void halves_to_scaled_floats(const uint8_t* in, float factor, float* out, size_t n);
// out[i] = sign(in[i]) sqrt(|in[i]|).
void signed_sqrt(const float* in, float* out, size_t n);
// Halves (at a byte offset, as above) that rounded to zero from a non-zero source value become
// the smallest subnormal of their sign.
void keep_nonzero(const float* source, uint8_t* halves, size_t n);
// The largest |x| over the finite values (0 when there are none).
float max_finite_abs(const float* v, size_t n);

}  // namespace chungs
