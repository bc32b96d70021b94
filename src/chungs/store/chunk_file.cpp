#include "chungs/store/chunk_file.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <optional>

#include "chungs/common/error.hpp"
#include "chungs/common/mapped_allocator.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/checksum.hpp"
#include "chungs/store/chunk_codec.hpp"
#include "chungs/store/zstd_limits.hpp"
#include "chungs/store/zstd_stream.hpp"

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

static_assert(kChunkFlagsHalf == (kChunkFlagHalfMoments | kChunkFlagHalfShRest));

// Pieces of the payload pass through a buffer of the thread's, so that a file is a few large reads or
// writes and not one per converted piece and scale (a syscall each made a chunk of 3,000 Gaussians
// 45 % slower to write and read); arrays as large as half of it go straight through.
constexpr size_t kIoBuffer = size_t(512) << 10;
uint8_t* io_buffer() {
  thread_local MappedVector<uint8_t> b(kIoBuffer);
  return b.data();
}

class BufferedAppend {
 public:
  explicit BufferedAppend(const Append& append) : append_(append) {}
  void operator()(const void* data, size_t size) {
    // What is buffered goes first, also before an array that goes straight through: without that, an
    // array of 256-512 KB overtook up to 256 KB of the fields before it, in float32 files of 1,366-2,259
    // Gaussians and in half-precision files of 65,536 or more (their bookkeeping words); the payload
    // checksum refused such a file, so its chunk could not be loaded back.
    if (size >= kIoBuffer / 2) {
      flush();
      append_(data, size);
      return;
    }
    if (used_ + size > kIoBuffer) flush();
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

// Checks a zstd payload at the file's current offset before anything is allocated for it: its
// checksum, and the content size its frame declares.
void check_zstd_payload(const FileDescriptor& fd, const fs::path& file, uint64_t packed, uint64_t checksum,
                        uint64_t raw_bytes) {
  Xxh64 sum;
  uint8_t frame_header[18];  // a frame header's most (ZSTD_FRAMEHEADERSIZE_MAX): all the declared size needs
  size_t header_bytes = 0;
  for (uint64_t left = packed; left > 0;) {
    const size_t n = size_t(std::min<uint64_t>(kIoBuffer, left));
    read_exact(fd, io_buffer(), n, file);
    if (left == packed) std::memcpy(frame_header, io_buffer(), header_bytes = std::min(n, sizeof frame_header));
    sum.update(io_buffer(), n);
    left -= n;
  }
  if (sum.digest() != checksum) fail(file.string(), ": payload checksum mismatch: the file is corrupt");
  check_zstd_content_size(file, frame_header, header_bytes, raw_bytes);
}

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
  const uint32_t half = h.flags;
  if (opt.compress) h.flags |= kChunkFlagZstd | (opt.shuffle ? kChunkFlagShuffled : 0);
  // Written as it is encoded (and compressed), the header last: a thread writing chunks holds no
  // copy of one.
  write_file_atomically(
      file, {&h, sizeof h},
      [&](const Append& append) {
        Xxh64 sum;
        uint64_t raw = 0, packed = 0;
        BufferedAppend out(append);
        auto store = [&](const void* data, size_t size) {
          sum.update(data, size);
          packed += size;
          out(data, size);
        };
        std::optional<ZstdWriter> zstd;
        if (opt.compress) zstd.emplace(opt.zstd_level, h.raw_bytes, file, store);
        auto emit = [&](const void* data, size_t size) {
          raw += size;
          zstd ? zstd->feed(data, size) : store(data, size);
        };
        if (opt.compress && opt.shuffle)
          encode_shuffled_payload(block, half, emit);
        else
          encode_payload(block, half, emit);
        if (zstd) zstd->end();
        out.flush();
        if (raw != h.raw_bytes)
          fail(file.string(), ": internal error: ", raw, " payload bytes written for ", h.raw_bytes);
        h.payload_bytes = packed;
        h.payload_checksum = sum.digest();
        h.header_checksum = xxh64(&h, kChecksummedHeaderBytes);
      },
      opt.durable, opt.start_writeback);
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
  // the payload, but only the header speaks for the block. It is then read again as it decompresses.
  const bool zstd = h.flags & kChunkFlagZstd;
  if (zstd) {
    check_zstd_payload(fd, file, h.payload_bytes, h.payload_checksum, h.raw_bytes);
    if (::lseek(fd.get(), sizeof h, SEEK_SET) != off_t(sizeof h))
      fail(file.string(), ": cannot seek: ", std::strerror(errno));
  }
  const BlockArrays b = place(h.count, int(h.sh_degree));
  // The reader sized its room from the manifest: a file of another chunk (copied over this one) shows here
  // first, so name the chunk its header holds.
  if (b.count != h.count)
    fail(file.string(), ": holds ", h.count, " Gaussians of ", chunk_name(ChunkId(h.chunk_id)), " where ", b.count,
         " were expected (a file of another chunk or another commit)");
  const uint32_t half = h.flags & kChunkFlagsHalf;
  if (zstd) {
    ZstdReader unpack(fd, file, h.payload_bytes);
    const auto in = [&](void* data, size_t bytes) { unpack(data, bytes); };
    if (h.flags & kChunkFlagShuffled)
      decode_shuffled_payload(b, half, in);
    else
      decode_payload(b, half, in);
    unpack.finish();
  } else {
    Xxh64 sum;
    BufferedRead in(fd, file, h.payload_bytes);
    decode_payload(b, half, [&](void* data, size_t bytes) {
      in(data, bytes);
      sum.update(data, bytes);
    });
    if (sum.digest() != h.payload_checksum)
      fail(file.string(), ": payload checksum mismatch: the file is corrupt");
  }
  return info_of(h, size);
}

}  // namespace chungs
