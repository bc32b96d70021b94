// Chunk and keyframe files end their fixed header with two xxh64 sums: the payload's, then the
// header's own over the bytes before it. Recomputing both over a mutated input lets it past the
// checksum tests to the decoder behind them, which is what the fuzzing is for.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "chungs/store/checksum.hpp"

namespace chungs::fuzz {

inline void reseal(std::vector<uint8_t>& bytes, size_t header_bytes, size_t payload_checksum_at,
                   size_t header_checksum_at) {
  if (bytes.size() < header_bytes) return;
  const uint64_t payload = xxh64(bytes.data() + header_bytes, bytes.size() - header_bytes);
  std::memcpy(bytes.data() + payload_checksum_at, &payload, sizeof payload);
  const uint64_t header = xxh64(bytes.data(), header_checksum_at);
  std::memcpy(bytes.data() + header_checksum_at, &header, sizeof header);
}

}  // namespace chungs::fuzz
