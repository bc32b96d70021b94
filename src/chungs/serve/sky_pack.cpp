#include "chungs/serve/sky_pack.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "chungs/common/error.hpp"

namespace chungs::serve {

std::string pack_sky(const SkyTexture& sky) {
  if (sky.empty()) fail("no sky texture to pack");
  sky.check();
  const size_t texels = sky.texels();
  std::string out(kSkyPackHeaderBytes + 4 * texels, '\0');
  char* p = out.data();
  std::memcpy(p, "DCSKYTX1", 8);
  const uint32_t size[2] = {uint32_t(sky.width), uint32_t(sky.height)};
  std::memcpy(p + 8, size, sizeof size);
  std::memcpy(p + 16, sky.axes, sizeof sky.axes);
  auto* t = reinterpret_cast<uint8_t*>(p + kSkyPackHeaderBytes);
  for (size_t i = 0; i < texels; ++i) {
    for (int c = 0; c < 3; ++c) t[4 * i + c] = uint8_t(std::lround(std::clamp(sky.rgb[3 * i + c], 0.f, 1.f) * 255));
    t[4 * i + 3] = sky.updates[i] > 0 ? 255 : 0;
  }
  return out;
}

}  // namespace chungs::serve
