#include "chungs/store/keyframe_file.hpp"

#include <zstd.h>

#include <cstring>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/checksum.hpp"
#include "chungs/store/zstd_limits.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {
constexpr char kMagic[8] = {'C', 'H', 'G', 'S', 'K', 'F', 'R', 'M'};
constexpr uint32_t kFlagZstd = 1;

struct Header {
  char magic[8];
  uint32_t version, header_size;
  uint64_t id;
  int32_t color_w, color_h, color_c, depth_w, depth_h, depth_c;
  uint32_t flags, reserved;
  uint64_t payload_bytes, raw_bytes, payload_checksum, header_checksum;
};
static_assert(sizeof(Header) == 88, "keyframe header must have no padding");
constexpr size_t kChecksummed = offsetof(Header, header_checksum);

bool shape_ok(int32_t w, int32_t h, int32_t c, bool allow_empty) {
  if (allow_empty && w == 0 && h == 0 && c == 0) return true;
  return w > 0 && h > 0 && c >= 1 && c <= 4;
}

// Pixels of an image whose shape passed shape_ok; refused naming the file and the image beyond any
// image we read (a 32768x32768 keyframe once took 8.6 GB on `run --resume`).
uint64_t declared_pixels(const std::string& f, const char* image, int32_t w, int32_t h) {
  const uint64_t pixels = uint64_t(w) * uint64_t(h);
  if (pixels > kMaxImagePixels)
    fail(f, ": header's ", image, " of ", w, " x ", h, " pixels is more than the ", kMaxImagePixels,
         " an image may have");
  return pixels;
}
}  // namespace

uint64_t write_keyframe_file(const fs::path& file, uint64_t id, const KeyframeImages& im,
                             const KeyframeWriteOptions& opt) {
  if (im.color.empty()) fail(file.string(), ": keyframe ", id, " has no colour image");
  if (!im.depth.empty() && im.depth.channels() != 1)
    fail(file.string(), ": keyframe ", id, " depth must have 1 channel, has ", im.depth.channels());
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kKeyframeFormatVersion;
  h.header_size = sizeof h;
  h.id = id;
  h.color_w = im.color.width(), h.color_h = im.color.height(), h.color_c = im.color.channels();
  if (!im.depth.empty()) h.depth_w = im.depth.width(), h.depth_h = im.depth.height(), h.depth_c = 1;
  h.raw_bytes = im.bytes();
  std::vector<ConstBuffer> parts{{&h, sizeof h}};
  std::vector<uint8_t> packed;
  Xxh64 sum;
  if (opt.compress) {
    h.flags = kFlagZstd;
    std::vector<uint8_t> raw(h.raw_bytes);
    std::memcpy(raw.data(), im.color.data(), im.color.size());
    if (!im.depth.empty()) std::memcpy(raw.data() + im.color.size(), im.depth.data(), im.depth.size() * 4);
    packed.resize(ZSTD_compressBound(raw.size()));
    const size_t n = ZSTD_compress(packed.data(), packed.size(), raw.data(), raw.size(), opt.zstd_level);
    if (ZSTD_isError(n)) fail(file.string(), ": zstd compression failed: ", ZSTD_getErrorName(n));
    packed.resize(n);
    parts.push_back({packed.data(), packed.size()});
  } else {
    parts.push_back({im.color.data(), im.color.size()});
    parts.push_back({im.depth.data(), im.depth.size() * 4});
  }
  for (size_t i = 1; i < parts.size(); ++i) {
    sum.update(parts[i].data, parts[i].size);
    h.payload_bytes += parts[i].size;
  }
  h.payload_checksum = sum.digest();
  h.header_checksum = xxh64(&h, kChecksummed);
  write_file_atomically(file, parts, opt.durable);
  return sizeof h + h.payload_bytes;
}

uint64_t read_keyframe_file(const fs::path& file, KeyframeImages& out, uint64_t* bytes_read) {
  const std::string f = file.string();
  FileDescriptor fd = open_for_reading(file);
  const uint64_t size = file_size(fd, file);
  Header h;
  if (size < sizeof h) fail(f, ": not a keyframe file (shorter than a header)");
  read_exact(fd, &h, sizeof h, file);
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) fail(f, ": not a keyframe file (bad magic)");
  if (h.version != kKeyframeFormatVersion)
    fail(f, ": keyframe format version ", h.version, " is not supported (this build reads ",
         kKeyframeFormatVersion, ")");
  if (h.header_size != sizeof h || xxh64(&h, kChecksummed) != h.header_checksum)
    fail(f, ": header checksum mismatch: the file is corrupt");
  if (!shape_ok(h.color_w, h.color_h, h.color_c, false) || !shape_ok(h.depth_w, h.depth_h, h.depth_c, true) ||
      h.depth_c > 1 || (h.flags & ~kFlagZstd))
    fail(f, ": implausible image shapes or flags in the header");
  // Every size is checked against the file before anything is allocated for it.
  const uint64_t raw_bytes = declared_pixels(f, "colour image", h.color_w, h.color_h) * uint64_t(h.color_c) +
                             declared_pixels(f, "depth map", h.depth_w, h.depth_h) * sizeof(float);
  if (h.raw_bytes != raw_bytes) fail(f, ": payload size ", h.raw_bytes, " does not match the image shapes");
  const bool zstd = h.flags & kFlagZstd;
  if (zstd)
    check_zstd_expansion(
        file, cat("colour ", h.color_w, " x ", h.color_h, " and depth ", h.depth_w, " x ", h.depth_h),
        h.raw_bytes, h.payload_bytes);
  else if (h.payload_bytes != h.raw_bytes)
    fail(f, ": uncompressed payload of ", h.payload_bytes, " bytes should be ", h.raw_bytes);
  if (size != sizeof h + h.payload_bytes)
    fail(f, ": file has ", size, " bytes but its header announces ", sizeof h + h.payload_bytes);
  std::vector<uint8_t> payload(h.payload_bytes);
  read_exact(fd, payload.data(), payload.size(), file);
  if (xxh64(payload.data(), payload.size()) != h.payload_checksum)
    fail(f, ": payload checksum mismatch: the file is corrupt");
  if (zstd) check_zstd_content_size(file, payload.data(), payload.size(), h.raw_bytes);
  KeyframeImages im;
  im.color = Image8(h.color_w, h.color_h, h.color_c);
  if (h.depth_c) im.depth = ImageF(h.depth_w, h.depth_h, 1);
  const uint8_t* raw = payload.data();
  std::vector<uint8_t> unpacked;
  if (zstd) {
    unpacked.resize(h.raw_bytes);
    const size_t n = ZSTD_decompress(unpacked.data(), unpacked.size(), payload.data(), payload.size());
    if (ZSTD_isError(n) || n != h.raw_bytes) fail(f, ": compressed payload is corrupt");
    raw = unpacked.data();
  }
  std::memcpy(im.color.data(), raw, im.color.size());
  if (!im.depth.empty()) std::memcpy(im.depth.data(), raw + im.color.size(), im.depth.size() * 4);
  out = std::move(im);
  if (bytes_read) *bytes_read = size;
  return h.id;
}

}  // namespace chungs
