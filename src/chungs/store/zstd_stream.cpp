#include "chungs/store/zstd_stream.hpp"

#include <algorithm>
#include <memory>

#include "chungs/common/error.hpp"
#include "chungs/common/mapped_allocator.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {

struct CCtxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxFree {
  void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};
// One context per thread: creating one per file costs more than compressing a small chunk.
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

uint8_t* out_buffer() {
  thread_local MappedVector<uint8_t> b(ZSTD_CStreamOutSize());
  return b.data();
}
uint8_t* in_buffer() {
  thread_local MappedVector<uint8_t> b(ZSTD_DStreamInSize());
  return b.data();
}

}  // namespace

ZstdWriter::ZstdWriter(int level, uint64_t content_bytes, const fs::path& file, Sink sink)
    : c_(compressor()), file_(file), sink_(std::move(sink)) {
  ZSTD_CCtx_reset(c_, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(c_, ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setPledgedSrcSize(c_, content_bytes);
}

void ZstdWriter::feed(const void* data, size_t size) {
  ZSTD_inBuffer in{data, size, 0};
  while (in.pos < in.size) step(in, ZSTD_e_continue);
}

void ZstdWriter::end() {
  ZSTD_inBuffer none{nullptr, 0, 0};
  while (step(none, ZSTD_e_end) != 0) {
  }
}

size_t ZstdWriter::step(ZSTD_inBuffer& in, ZSTD_EndDirective mode) {
  ZSTD_outBuffer out{out_buffer(), ZSTD_CStreamOutSize(), 0};
  const size_t left = ZSTD_compressStream2(c_, &out, &in, mode);
  if (ZSTD_isError(left)) fail(file_.string(), ": zstd compression failed: ", ZSTD_getErrorName(left));
  if (out.pos) sink_(out.dst, out.pos);
  return left;
}

ZstdReader::ZstdReader(const FileDescriptor& fd, const fs::path& file, uint64_t packed)
    : d_(decompressor()), fd_(fd), file_(file), left_(packed) {
  ZSTD_DCtx_reset(d_, ZSTD_reset_session_and_parameters);
}

void ZstdReader::operator()(void* dst, size_t size) {
  ZSTD_outBuffer out{dst, size, 0};
  while (out.pos < out.size) {
    refill();
    const size_t in_before = in_.pos, out_before = out.pos;
    last_ = ZSTD_decompressStream(d_, &out, &in_);
    if (ZSTD_isError(last_)) fail(file_.string(), ": zstd payload is corrupt: ", ZSTD_getErrorName(last_));
    if (in_.pos == in_before && out.pos == out_before && left_ == 0)
      fail(file_.string(), ": compressed payload ends before all arrays were read");
  }
}

void ZstdReader::finish() {
  if (last_ != 0) {  // the frame's end mark may still be unread after the last byte came out
    refill();
    ZSTD_outBuffer none{nullptr, 0, 0};
    last_ = ZSTD_decompressStream(d_, &none, &in_);
    if (ZSTD_isError(last_)) fail(file_.string(), ": zstd payload is corrupt: ", ZSTD_getErrorName(last_));
  }
  if (last_ != 0 || in_.pos != in_.size || left_ != 0)
    fail(file_.string(), ": compressed payload has trailing or unterminated data");
}

void ZstdReader::refill() {
  if (in_.pos < in_.size || left_ == 0) return;
  const size_t n = size_t(std::min<uint64_t>(ZSTD_DStreamInSize(), left_));
  read_exact(fd_, in_buffer(), n, file_);
  left_ -= n;
  in_ = {in_buffer(), n, 0};
}

}  // namespace chungs
