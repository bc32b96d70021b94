// A zstd frame written and read as a stream of small pieces, with one compression and one
// decompression context per thread: a thread that writes or reads compressed files holds its
// contexts and buffers of ~128 KB, never a copy of a file's content or of its compressed bytes
// (chunk files, bench/README.md: 16 threads held 162 MB after chunks of 10 k Gaussians).
#pragma once
#include <zstd.h>

#include <cstdint>
#include <filesystem>
#include <functional>

#include "chungs/store/atomic_file.hpp"

namespace chungs {

// Compresses what feed() is given into one frame of `content_bytes` (declared in its header), handing
// the compressed bytes to `sink` as they are made. Errors name `file`.
class ZstdWriter {
 public:
  using Sink = std::function<void(const void*, size_t)>;
  ZstdWriter(int level, uint64_t content_bytes, const std::filesystem::path& file, Sink sink);
  ZstdWriter(const ZstdWriter&) = delete;
  void feed(const void* data, size_t size);
  void end();  // the frame's end; nothing may be fed after it

 private:
  size_t step(ZSTD_inBuffer& in, ZSTD_EndDirective mode);
  ZSTD_CCtx* c_;
  std::filesystem::path file_;
  Sink sink_;
};

// The content of a zstd frame of `packed` bytes at the file's current offset, in order: read(dst, size)
// fills dst with the next bytes; finish() checks that the frame ended where the packed bytes do.
class ZstdReader {
 public:
  ZstdReader(const FileDescriptor& fd, const std::filesystem::path& file, uint64_t packed);
  ZstdReader(const ZstdReader&) = delete;  // its state is where the stream is
  void operator()(void* dst, size_t size);
  void finish();

 private:
  void refill();
  ZSTD_DCtx* d_;
  const FileDescriptor& fd_;
  std::filesystem::path file_;
  uint64_t left_;  // packed bytes not yet read from the file
  ZSTD_inBuffer in_{nullptr, 0, 0};
  size_t last_ = 1;  // what the last decompression call returned: 0 once the frame is complete
};

}  // namespace chungs
