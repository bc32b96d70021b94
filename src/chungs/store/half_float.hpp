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

}  // namespace chungs
