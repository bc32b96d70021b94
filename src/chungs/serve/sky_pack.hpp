// The map's learned sky (sky.bin, render/sky.hpp) packed for the page (GET /api/sky): the texture's
// colours as RGBA8 texels the page uploads as one WebGL texture, and the sky frame's axes so the
// page looks it up by direction exactly as the renderer does (equirectangular about "up", azimuth
// wrapping, elevation clamped at the poles, bilinear between texel centres).
//
// Layout (version 1), little-endian:
//   offset  0  char[8]    magic "DCSKYTX1"
//           8  uint32     width (texels over azimuth, -pi at the left edge)
//          12  uint32     height (texels over elevation, row 0 at the zenith)
//          16  float32[9] rows: the sky frame's east, north and up axes in world coordinates
//          52  uint32[3]  zero
//          64  uint8[4 * width * height] r, g, b, a per texel, row-major, colour * 255 rounded; a is
//                        255 for a texel some step trained and 0 for one no view saw (still the black
//                        it started as: above and below the cameras' field of view), which the page
//                        may fill from its trained neighbours for views wider than the cameras'
// Eight bits per channel: the page draws into an 8-bit canvas, so the rounding (at most half a
// level) is below what it can show.
#pragma once
#include <cstdint>
#include <string>

#include "chungs/render/sky.hpp"

namespace chungs::serve {

constexpr uint32_t kSkyPackHeaderBytes = 64;

// Throws Error when the texture is empty or its sizes do not match.
std::string pack_sky(const SkyTexture& sky);

}  // namespace chungs::serve
