// IEEE 754 binary16 conversions (round to nearest, ties to even; subnormals, infinities and NaN
// kept), for storing optimiser state at half the size.
#pragma once
#include <cstdint>

namespace chungs {

uint16_t float_to_half(float f);
float half_to_float(uint16_t h);

}  // namespace chungs
