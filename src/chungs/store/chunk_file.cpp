#include "chungs/store/chunk_file.hpp"

#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/checksum.hpp"
#include "chungs/store/chunk_codec.hpp"
#include "chungs/store/zstd_limits.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'C', 'H', 'G', 'S', 'C', 'H', 'N', 'K'};

struct Header {
  char magic[8];
  uint32_t version, header_size;
  uint64_t chunk_id, count;
  uint32_t sh_degree, flags;
  uint64_t payload_bytes, raw_bytes, payload_checksum, header_checksum;
};
static_assert(sizeof(Header) == 72, "chunk header must have no padding");
constexpr size_t kChecksummedHeaderBytes = offsetof(Header, header_checksum);

using Arrays = std::vector<PayloadArray>;
static_assert(kChunkFlagsHalf == (kChunkFlagHalfMoments | kChunkFlagHalfShRest));

// Byte shuffle over elements of w bytes: all first bytes, then all second bytes, ...
void shuffle(const uint8_t* in, uint8_t* out, size_t bytes, int w) {
  const size_t n = bytes / size_t(w);
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < w; ++k) out[size_t(k) * n + i] = in[size_t(w) * i + size_t(k)];
}
void unshuffle(const uint8_t* in, uint8_t* out, size_t bytes, int w) {
  const size_t n = bytes / size_t(w);
  for (int k = 0; k < w; ++k)
    for (size_t i = 0; i < n; ++i) out[size_t(w) * i + size_t(k)] = in[size_t(k) * n + i];
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

std::vector<uint8_t> compress(const Arrays& arrays, uint64_t raw_bytes, const ChunkWriteOptions& opt,
                              const fs::path& file) {
  ZSTD_CCtx* c = compressor();
  ZSTD_CCtx_reset(c, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(c, ZSTD_c_compressionLevel, opt.zstd_level);
  ZSTD_CCtx_setPledgedSrcSize(c, raw_bytes);
  std::vector<uint8_t> out(ZSTD_compressBound(raw_bytes)), scratch;
  ZSTD_outBuffer ob{out.data(), out.size(), 0};
  for (size_t a = 0; a <= arrays.size(); ++a) {
    const bool last = a == arrays.size();
    ZSTD_inBuffer ib{nullptr, 0, 0};
    if (!last) {
      const size_t bytes = arrays[a].bytes;
      ib.src = arrays[a].data;
      ib.size = bytes;
      if (opt.shuffle) {
        scratch.resize(bytes);
        shuffle(arrays[a].data, scratch.data(), bytes, arrays[a].element_bytes);
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

void decompress(const std::vector<uint8_t>& in, const Arrays& arrays, bool shuffled, const fs::path& file) {
  ZSTD_DCtx* d = decompressor();
  ZSTD_DCtx_reset(d, ZSTD_reset_session_and_parameters);
  ZSTD_inBuffer ib{in.data(), in.size(), 0};
  std::vector<uint8_t> scratch;
  size_t ret = 1;
  for (const PayloadArray& a : arrays) {
    const size_t bytes = a.bytes;
    if (shuffled) scratch.resize(bytes);
    ZSTD_outBuffer ob{shuffled ? scratch.data() : a.data, bytes, 0};
    while (ob.pos < ob.size) {
      const size_t in_before = ib.pos, out_before = ob.pos;
      ret = ZSTD_decompressStream(d, &ob, &ib);
      if (ZSTD_isError(ret)) fail(file.string(), ": zstd payload is corrupt: ", ZSTD_getErrorName(ret));
      if (ib.pos == in_before && ob.pos == out_before)
        fail(file.string(), ": compressed payload ends before all arrays were read");
    }
    if (shuffled) unshuffle(scratch.data(), a.data, bytes, a.element_bytes);
  }
  if (ret != 0) {  // the frame's end mark may still be unread after the last byte came out
    ZSTD_outBuffer none{nullptr, 0, 0};
    ret = ZSTD_decompressStream(d, &none, &ib);
    if (ZSTD_isError(ret)) fail(file.string(), ": zstd payload is corrupt: ", ZSTD_getErrorName(ret));
  }
  if (ret != 0 || ib.pos != ib.size)
    fail(file.string(), ": compressed payload has trailing or unterminated data");
}

// Pieces of the payload pass through a buffer of the thread's, so that a file is a few large reads or
// writes and not one per converted piece and scale (a syscall each made a chunk of 3,000 Gaussians
// 45 % slower to write and read); arrays as large as half of it go straight through.
constexpr size_t kIoBuffer = size_t(512) << 10;
uint8_t* io_buffer() {
  thread_local std::unique_ptr<uint8_t[]> b = std::make_unique_for_overwrite<uint8_t[]>(kIoBuffer);
  return b.get();
}

class BufferedAppend {
 public:
  explicit BufferedAppend(const Append& append) : append_(append) {}
  void operator()(const void* data, size_t size) {
    // What is buffered goes first, also before an array that goes straight through: without that, an
    // array of 256-512 KB overtook up to 256 KB of the fields before it, in float32 files of 1,366-2,259
    // Gaussians and in half-precision files of 65,536 or more (their bookkeeping words); the payload
    // checksum refused such a file, so its chunk could not be loaded back.
    if (used_ + size > kIoBuffer || size >= kIoBuffer / 2) flush();
    if (size >= kIoBuffer / 2) {
      append_(data, size);
      return;
    }
    std::memcpy(io_buffer() + used_, data, size);
    used_ += size;
  }
  void flush() {
    if (used_) append_(io_buffer(), used_);
    used_ = 0;
  }

 private:
  const Append& append_;
  size_t used_ = 0;
};

// Reads `left` bytes of a file in order, ahead into the thread's buffer.
class BufferedRead {
 public:
  BufferedRead(const FileDescriptor& fd, const fs::path& file, uint64_t left) : fd_(fd), file_(file), left_(left) {}
  void operator()(void* dst, size_t size) {
    auto* out = static_cast<uint8_t*>(dst);
    const size_t now = std::min(size, end_ - at_);
    std::memcpy(out, io_buffer() + at_, now);
    at_ += now, out += now, size -= now;
    if (size == 0) return;
    if (size > left_) fail(file_.string(), ": truncated (", size - left_, " more bytes expected)");
    if (size >= kIoBuffer / 2) {
      read_exact(fd_, out, size, file_);
      left_ -= size;
      return;
    }
    end_ = size_t(std::min<uint64_t>(kIoBuffer, left_));
    read_exact(fd_, io_buffer(), end_, file_);
    left_ -= end_;
    std::memcpy(out, io_buffer(), size);
    at_ = size;
  }

 private:
  const FileDescriptor& fd_;
  const fs::path& file_;
  uint64_t left_;  // in the file, not yet read
  size_t at_ = 0, end_ = 0;
};

Header read_and_check_header(const FileDescriptor& fd, const fs::path& file, uint64_t& size) {
  size = file_size(fd, file);
  Header h;
  if (size < sizeof h) fail(file.string(), ": not a chunk file (", size, " bytes, shorter than a header)");
  read_exact(fd, &h, sizeof h, file);
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) fail(file.string(), ": not a chunk file (bad magic)");
  if (h.version < 1 || h.version > kChunkFormatVersion)
    fail(file.string(), ": chunk format version ", h.version,
         " is not supported (this build reads versions 1 to ", kChunkFormatVersion, ")");
  if (h.header_size != sizeof h)
    fail(file.string(), ": header size ", h.header_size, " should be ", sizeof h);
  if (xxh64(&h, kChecksummedHeaderBytes) != h.header_checksum)
    fail(file.string(), ": header checksum mismatch: the file is corrupt");
  if (h.count > kMaxChunkGaussians)
    fail(file.string(), ": header's Gaussian count ", h.count, " is more than a chunk may hold (",
         kMaxChunkGaussians, ")");
  if (h.sh_degree > uint32_t(kMaxShDegree)) fail(file.string(), ": SH degree ", h.sh_degree, " out of range");
  const uint32_t known = kChunkFlagZstd | kChunkFlagShuffled | (h.version >= 2 ? kChunkFlagsHalf : 0);
  if (h.flags & ~known)
    fail(file.string(), ": unknown flag bits in ", h.flags, " for chunk format version ", h.version);
  if (h.raw_bytes != chunk_payload_bytes(h.count, h.flags))
    fail(file.string(), ": payload of ", h.raw_bytes, " bytes does not fit ", h.count, " Gaussians");
  if (!(h.flags & kChunkFlagZstd) && h.payload_bytes != h.raw_bytes)
    fail(file.string(), ": uncompressed payload of ", h.payload_bytes, " bytes should be ", h.raw_bytes);
  if (h.flags & kChunkFlagZstd)
    check_zstd_expansion(file, cat(h.count, " Gaussians"), h.raw_bytes, h.payload_bytes);
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
  return write_chunk_file(file, id, block_arrays(block), opt);
}

ChunkFileInfo write_chunk_file(const fs::path& file, ChunkId id, const ConstBlockArrays& block,
                               const ChunkWriteOptions& opt) {
  if (block.sh_degree < 0 || block.sh_degree > kMaxShDegree)
    fail(file.string(), ": SH degree ", block.sh_degree, " is out of range 0..3");
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kChunkFormatVersion;
  h.header_size = sizeof h;
  h.chunk_id = id;
  h.count = block.count;
  h.sh_degree = uint32_t(block.sh_degree);
  h.flags = (opt.half_moments ? kChunkFlagHalfMoments : 0) | (opt.half_sh_rest ? kChunkFlagHalfShRest : 0);
  h.raw_bytes = chunk_payload_bytes(h.count, h.flags);
  if (opt.compress) {
    const ChunkEncoder encoder(block, h.flags);  // whole arrays: zstd shuffles each as one
    h.flags |= kChunkFlagZstd | (opt.shuffle ? kChunkFlagShuffled : 0);
    const std::vector<uint8_t> packed = compress(encoder.arrays(), h.raw_bytes, opt, file);
    h.payload_bytes = packed.size();
    h.payload_checksum = xxh64(packed.data(), packed.size());
    h.header_checksum = xxh64(&h, kChecksummedHeaderBytes);
    const ConstBuffer parts[] = {{&h, sizeof h}, {packed.data(), packed.size()}};
    write_file_atomically(file, parts, opt.durable, opt.start_writeback);
  } else {
    // Written as it is encoded, the header last: a thread writing chunks holds no copy of one.
    h.payload_bytes = h.raw_bytes;
    write_file_atomically(
        file, {&h, sizeof h},
        [&](const Append& append) {
          Xxh64 sum;
          uint64_t bytes = 0;
          BufferedAppend out(append);
          encode_payload(block, h.flags, [&](const void* data, size_t size) {
            sum.update(data, size);
            bytes += size;
            out(data, size);
          });
          out.flush();
          if (bytes != h.raw_bytes)
            fail(file.string(), ": internal error: ", bytes, " payload bytes written for ", h.raw_bytes);
          h.payload_checksum = sum.digest();
          h.header_checksum = xxh64(&h, kChecksummedHeaderBytes);
        },
        opt.durable, opt.start_writeback);
  }
  return info_of(h, sizeof h + h.payload_bytes);
}

ChunkFileInfo read_chunk_header(const fs::path& file) {
  FileDescriptor fd = open_for_reading(file);
  uint64_t size = 0;
  const Header h = read_and_check_header(fd, file, size);
  return info_of(h, size);
}

ChunkFileInfo read_chunk_file(const fs::path& file, GaussianBlock& out) {
  return read_chunk_file(open_for_reading(file), file, out);
}

ChunkFileInfo read_chunk_file(const FileDescriptor& fd, const fs::path& file, GaussianBlock& out) {
  GaussianBlock b;  // `out` changes only once the whole chunk read back
  const ChunkFileInfo info = read_chunk_file(fd, file, [&](uint64_t count, int sh_degree) {
    b.sh_degree = sh_degree;
    b.resize(count);
    return block_arrays(b);
  });
  out = std::move(b);
  return info;
}

ChunkFileInfo read_chunk_file(const FileDescriptor& fd, const fs::path& file, const ChunkPlacer& place) {
  if (::lseek(fd.get(), 0, SEEK_SET) != 0) fail(file.string(), ": cannot seek: ", std::strerror(errno));
  uint64_t size = 0;
  const Header h = read_and_check_header(fd, file, size);
  // A compressed payload is read and checked before the block is allocated: the file's length bounds
  // the payload, but only the header speaks for the block.
  const bool zstd = h.flags & kChunkFlagZstd;
  std::vector<uint8_t> packed;
  if (zstd) {
    packed.resize(h.payload_bytes);
    read_exact(fd, packed.data(), packed.size(), file);
    if (xxh64(packed.data(), packed.size()) != h.payload_checksum)
      fail(file.string(), ": payload checksum mismatch: the file is corrupt");
    check_zstd_content_size(file, packed.data(), packed.size(), h.raw_bytes);
  }
  const BlockArrays b = place(h.count, int(h.sh_degree));
  if (b.count != h.count) fail(file.string(), ": room for ", b.count, " Gaussians given for ", h.count);
  if (zstd) {
    ChunkDecoder decoder(b, h.flags & kChunkFlagsHalf);
    decompress(packed, decoder.arrays(), h.flags & kChunkFlagShuffled, file);
    decoder.finish();
  } else {
    Xxh64 sum;
    BufferedRead in(fd, file, h.payload_bytes);
    decode_payload(b, h.flags & kChunkFlagsHalf, [&](void* data, size_t bytes) {
      in(data, bytes);
      sum.update(data, bytes);
    });
    if (sum.digest() != h.payload_checksum)
      fail(file.string(), ": payload checksum mismatch: the file is corrupt");
  }
  return info_of(h, size);
}

}  // namespace chungs
