// XXH64 (the public xxHash 64-bit algorithm), written from its specification. Chunk and keyframe
// files carry it over their payload: fast enough (several GB/s) that verifying every load is cheap.
#pragma once
#include <cstddef>
#include <cstdint>

namespace chungs {

class Xxh64 {
 public:
  explicit Xxh64(uint64_t seed = 0);
  void update(const void* data, size_t len);
  uint64_t digest() const;

 private:
  uint64_t acc_[4];
  uint64_t seed_;
  uint64_t total_ = 0;
  unsigned char buf_[32];
  size_t buffered_ = 0;
};

uint64_t xxh64(const void* data, size_t len, uint64_t seed = 0);

}  // namespace chungs
