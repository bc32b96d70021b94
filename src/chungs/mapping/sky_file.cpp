#include "chungs/mapping/sky_file.hpp"

#include <cstring>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/checksum.hpp"

namespace chungs {

namespace {

constexpr char kMagic[8] = {'D', 'C', 'S', 'K', 'Y', '0', '0', '1'};

struct Header {
  char magic[8];
  int32_t width, height;
  float axes[9];
};

uint64_t payload_bytes(size_t texels) { return texels * (9 * sizeof(float) + sizeof(uint32_t)); }

}  // namespace

void write_sky_file(const std::filesystem::path& file, const SkyTexture& sky, bool durable) {
  sky.check();
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.width = sky.width;
  h.height = sky.height;
  std::memcpy(h.axes, sky.axes, sizeof h.axes);
  const size_t n3 = sky.rgb.size() * sizeof(float);
  const ConstBuffer body[] = {{&h, sizeof h},
                              {sky.rgb.data(), n3},
                              {sky.m1.data(), n3},
                              {sky.m2.data(), n3},
                              {sky.updates.data(), sky.updates.size() * sizeof(uint32_t)}};
  uint64_t sum = 0;
  for (const ConstBuffer& b : body) sum = xxh64(b.data, b.size, sum);
  const ConstBuffer parts[] = {body[0], body[1], body[2], body[3], body[4], {&sum, sizeof sum}};
  write_file_atomically(file, parts, durable);
}

SkyTexture read_sky_file(const std::filesystem::path& file) {
  const FileDescriptor fd = open_for_reading(file);
  const uint64_t size = file_size(fd, file);
  Header h{};
  if (size < sizeof h + sizeof(uint64_t))
    fail(file.string(), ": too short for a sky texture (", size, " bytes)");
  read_exact(fd, &h, sizeof h, file);
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0)
    fail(file.string(), ": not a sky texture (wrong magic)");
  if (h.width < 4 || h.width > 4096 || h.height < 2 || h.height > 2048)
    fail(file.string(), ": sky texture of ", h.width, "x", h.height, " texels is outside 4x2 .. 4096x2048");
  const size_t texels = size_t(h.width) * size_t(h.height);
  if (size != sizeof h + payload_bytes(texels) + sizeof(uint64_t))
    fail(file.string(), ": ", size, " bytes do not match a ", h.width, "x", h.height,
         " sky texture (truncated?)");
  SkyTexture s;
  s.width = h.width;
  s.height = h.height;
  std::memcpy(s.axes, h.axes, sizeof s.axes);
  s.rgb.resize(3 * texels);
  s.m1.resize(3 * texels);
  s.m2.resize(3 * texels);
  s.updates.resize(texels);
  const size_t n3 = s.rgb.size() * sizeof(float);
  read_exact(fd, s.rgb.data(), n3, file);
  read_exact(fd, s.m1.data(), n3, file);
  read_exact(fd, s.m2.data(), n3, file);
  read_exact(fd, s.updates.data(), texels * sizeof(uint32_t), file);
  uint64_t stored = 0;
  read_exact(fd, &stored, sizeof stored, file);
  uint64_t sum = xxh64(&h, sizeof h, 0);
  sum = xxh64(s.rgb.data(), n3, sum);
  sum = xxh64(s.m1.data(), n3, sum);
  sum = xxh64(s.m2.data(), n3, sum);
  sum = xxh64(s.updates.data(), texels * sizeof(uint32_t), sum);
  if (sum != stored) fail(file.string(), ": checksum mismatch (the sky texture is damaged)");
  try {
    s.check();
  } catch (const Error& e) {
    fail(file.string(), ": ", e.what());
  }
  return s;
}

}  // namespace chungs
