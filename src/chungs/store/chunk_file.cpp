#include "chungs/store/chunk_file.hpp"

#include <zstd.h>

#include <array>
#include <cstring>
#include <memory>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/checksum.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'C', 'H', 'G', 'S', 'C', 'H', 'N', 'K'};
constexpr uint64_t kMaxCount = uint64_t(1) << 28;  // far above any chunk; bounds corrupt headers

struct Header {
  char magic[8];
  uint32_t version, header_size;
  uint64_t chunk_id, count;
  uint32_t sh_degree, flags;
  uint64_t payload_bytes, raw_bytes, payload_checksum, header_checksum;
};
static_assert(sizeof(Header) == 72, "chunk header must have no padding");
constexpr size_t kChecksummedHeaderBytes = offsetof(Header, header_checksum);

// The payload arrays in file order. Every element is 4 bytes, which the byte shuffle relies on.
struct Array {
  void* data;
  size_t elements;
};
constexpr int kArrays = 19;

std::array<Array, kArrays> arrays_of(const GaussianBlock& cb) {
  auto& b = const_cast<GaussianBlock&>(cb);  // the writer only reads through these pointers
  std::array<Array, kArrays> a;
  int k = 0;
  for (GaussianParams* p : {&b.params, &b.adam_m, &b.adam_v})
    for (std::vector<float>* v : {&p->mean, &p->log_scale, &p->rotation, &p->opacity, &p->sh})
      a[k++] = {v->data(), v->size()};
  for (std::vector<uint32_t>* v : {&b.adam_steps, &b.created_by_keyframe, &b.created_at_step})
    a[k++] = {v->data(), v->size()};
  a[k++] = {b.lr_position_factor.data(), b.lr_position_factor.size()};
  return a;
}

void shuffle4(const uint8_t* in, uint8_t* out, size_t n) {
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 4; ++k) out[size_t(k) * n + i] = in[4 * i + k];
}
void unshuffle4(const uint8_t* in, uint8_t* out, size_t n) {
  for (int k = 0; k < 4; ++k)
    for (size_t i = 0; i < n; ++i) out[4 * i + k] = in[size_t(k) * n + i];
}

struct CCtxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxFree {
  void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};
// One context per thread: creating one per chunk costs more than compressing a small chunk.
ZSTD_CCtx* compressor() {
  thread_local std::unique_ptr<ZSTD_CCtx, CCtxFree> c(ZSTD_createCCtx());
  if (!c) fail("zstd: cannot create a compression context");
  return c.get();
}
ZSTD_DCtx* decompressor() {
  thread_local std::unique_ptr<ZSTD_DCtx, DCtxFree> d(ZSTD_createDCtx());
  if (!d) fail("zstd: cannot create a decompression context");
  return d.get();
}

std::vector<uint8_t> compress(const std::array<Array, kArrays>& arrays, uint64_t raw_bytes,
                              const ChunkWriteOptions& opt, const fs::path& file) {
  ZSTD_CCtx* c = compressor();
  ZSTD_CCtx_reset(c, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(c, ZSTD_c_compressionLevel, opt.zstd_level);
  ZSTD_CCtx_setPledgedSrcSize(c, raw_bytes);
  std::vector<uint8_t> out(ZSTD_compressBound(raw_bytes)), scratch;
  ZSTD_outBuffer ob{out.data(), out.size(), 0};
  for (int a = 0; a <= kArrays; ++a) {
    const bool last = a == kArrays;
    ZSTD_inBuffer ib{nullptr, 0, 0};
    if (!last) {
      const size_t bytes = arrays[a].elements * 4;
      ib.src = arrays[a].data;
      ib.size = bytes;
      if (opt.shuffle) {
        scratch.resize(bytes);
        shuffle4(static_cast<const uint8_t*>(arrays[a].data), scratch.data(), arrays[a].elements);
        ib.src = scratch.data();
      }
    }
    size_t left;
    do {
      left = ZSTD_compressStream2(c, &ob, &ib, last ? ZSTD_e_end : ZSTD_e_continue);
      if (ZSTD_isError(left)) fail(file.string(), ": zstd compression failed: ", ZSTD_getErrorName(left));
    } while (last ? left != 0 : ib.pos < ib.size);
  }
  out.resize(ob.pos);
  return out;
}

void decompress(const std::vector<uint8_t>& in, const std::array<Array, kArrays>& arrays, bool shuffled,
                const fs::path& file) {
  ZSTD_DCtx* d = decompressor();
  ZSTD_DCtx_reset(d, ZSTD_reset_session_and_parameters);
  ZSTD_inBuffer ib{in.data(), in.size(), 0};
  std::vector<uint8_t> scratch;
  size_t ret = 1;
  for (const Array& a : arrays) {
    const size_t bytes = a.elements * 4;
    if (shuffled) scratch.resize(bytes);
    ZSTD_outBuffer ob{shuffled ? scratch.data() : a.data, bytes, 0};
    while (ob.pos < ob.size) {
      const size_t in_before = ib.pos, out_before = ob.pos;
      ret = ZSTD_decompressStream(d, &ob, &ib);
      if (ZSTD_isError(ret)) fail(file.string(), ": zstd payload is corrupt: ", ZSTD_getErrorName(ret));
      if (ib.pos == in_before && ob.pos == out_before)
        fail(file.string(), ": compressed payload ends before all arrays were read");
    }
    if (shuffled) unshuffle4(scratch.data(), static_cast<uint8_t*>(a.data), a.elements);
  }
  if (ret != 0) {  // the frame's end mark may still be unread after the last byte came out
    ZSTD_outBuffer none{nullptr, 0, 0};
    ret = ZSTD_decompressStream(d, &none, &ib);
    if (ZSTD_isError(ret)) fail(file.string(), ": zstd payload is corrupt: ", ZSTD_getErrorName(ret));
  }
  if (ret != 0 || ib.pos != ib.size)
    fail(file.string(), ": compressed payload has trailing or unterminated data");
}

Header read_and_check_header(const FileDescriptor& fd, const fs::path& file, uint64_t& size) {
  size = file_size(fd, file);
  Header h;
  if (size < sizeof h) fail(file.string(), ": not a chunk file (", size, " bytes, shorter than a header)");
  read_exact(fd, &h, sizeof h, file);
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) fail(file.string(), ": not a chunk file (bad magic)");
  if (h.version != kChunkFormatVersion)
    fail(file.string(), ": chunk format version ", h.version, " is not supported (this build reads version ",
         kChunkFormatVersion, ")");
  if (h.header_size != sizeof h) fail(file.string(), ": header size ", h.header_size, " should be ", sizeof h);
  if (xxh64(&h, kChecksummedHeaderBytes) != h.header_checksum)
    fail(file.string(), ": header checksum mismatch: the file is corrupt");
  if (h.count > kMaxCount) fail(file.string(), ": implausible Gaussian count ", h.count);
  if (h.sh_degree > uint32_t(kMaxShDegree)) fail(file.string(), ": SH degree ", h.sh_degree, " out of range");
  if (h.flags & ~(kChunkFlagZstd | kChunkFlagShuffled)) fail(file.string(), ": unknown flag bits in ", h.flags);
  if (h.raw_bytes != h.count * kChunkBytesPerGaussian)
    fail(file.string(), ": payload of ", h.raw_bytes, " bytes does not fit ", h.count, " Gaussians");
  if (!(h.flags & kChunkFlagZstd) && h.payload_bytes != h.raw_bytes)
    fail(file.string(), ": uncompressed payload of ", h.payload_bytes, " bytes should be ", h.raw_bytes);
  if (size != sizeof h + h.payload_bytes)
    fail(file.string(), ": file has ", size, " bytes but its header announces ", sizeof h + h.payload_bytes,
         " (truncated or trailing data)");
  return h;
}

ChunkFileInfo info_of(const Header& h, uint64_t size) {
  return {h.chunk_id, h.count, int(h.sh_degree), h.flags, size, h.payload_checksum};
}

}  // namespace

ChunkFileInfo write_chunk_file(const fs::path& file, ChunkId id, const GaussianBlock& block,
                          const ChunkWriteOptions& opt) {
  block.validate(file.c_str());
  const auto arrays = arrays_of(block);
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kChunkFormatVersion;
  h.header_size = sizeof h;
  h.chunk_id = id;
  h.count = block.size();
  h.sh_degree = uint32_t(block.sh_degree);
  h.raw_bytes = h.count * kChunkBytesPerGaussian;
  std::vector<uint8_t> packed;
  std::vector<ConstBuffer> parts{{&h, sizeof h}};
  Xxh64 sum;
  if (opt.compress) {
    h.flags = kChunkFlagZstd | (opt.shuffle ? kChunkFlagShuffled : 0);
    packed = compress(arrays, h.raw_bytes, opt, file);
    sum.update(packed.data(), packed.size());
    parts.push_back({packed.data(), packed.size()});
    h.payload_bytes = packed.size();
  } else {
    for (const Array& a : arrays) {
      sum.update(a.data, a.elements * 4);
      parts.push_back({a.data, a.elements * 4});
    }
    h.payload_bytes = h.raw_bytes;
  }
  h.payload_checksum = sum.digest();
  h.header_checksum = xxh64(&h, kChecksummedHeaderBytes);
  write_file_atomically(file, parts, opt.durable);
  return info_of(h, sizeof h + h.payload_bytes);
}

ChunkFileInfo read_chunk_header(const fs::path& file) {
  FileDescriptor fd = open_for_reading(file);
  uint64_t size = 0;
  const Header h = read_and_check_header(fd, file, size);
  return info_of(h, size);
}

ChunkFileInfo read_chunk_file(const fs::path& file, GaussianBlock& out) {
  FileDescriptor fd = open_for_reading(file);
  uint64_t size = 0;
  const Header h = read_and_check_header(fd, file, size);
  GaussianBlock b;
  b.sh_degree = int(h.sh_degree);
  b.resize(h.count);
  const auto arrays = arrays_of(b);
  Xxh64 sum;
  if (h.flags & kChunkFlagZstd) {
    std::vector<uint8_t> packed(h.payload_bytes);
    read_exact(fd, packed.data(), packed.size(), file);
    sum.update(packed.data(), packed.size());
    if (sum.digest() != h.payload_checksum)
      fail(file.string(), ": payload checksum mismatch: the file is corrupt");
    decompress(packed, arrays, h.flags & kChunkFlagShuffled, file);
  } else {
    for (const Array& a : arrays) {
      read_exact(fd, a.data, a.elements * 4, file);
      sum.update(a.data, a.elements * 4);
    }
    if (sum.digest() != h.payload_checksum)
      fail(file.string(), ": payload checksum mismatch: the file is corrupt");
  }
  out = std::move(b);
  return info_of(h, size);
}

}  // namespace chungs
