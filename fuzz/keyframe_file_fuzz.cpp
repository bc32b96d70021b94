// Keyframe files (store/keyframe_file.hpp): colour and optional depth, raw or zstd. Both
// checksums are recomputed over the mutated bytes so inputs reach the shape checks and the
// decompression behind them.
#include <cstring>
#include <vector>

#include "chungs/store/checksum.hpp"
#include "chungs/store/keyframe_file.hpp"
#include "fuzz_input.hpp"

namespace {

// Offsets in the 88-byte header (keyframe_file.cpp).
constexpr size_t kHeaderBytes = 88;
constexpr size_t kPayloadChecksumAt = 72;
constexpr size_t kHeaderChecksumAt = 80;

void reseal(std::vector<uint8_t>& bytes) {
  if (bytes.size() < kHeaderBytes) return;
  const uint64_t payload = chungs::xxh64(bytes.data() + kHeaderBytes, bytes.size() - kHeaderBytes);
  std::memcpy(bytes.data() + kPayloadChecksumAt, &payload, sizeof payload);
  const uint64_t header = chungs::xxh64(bytes.data(), kHeaderChecksumAt);
  std::memcpy(bytes.data() + kHeaderChecksumAt, &header, sizeof header);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  reseal(bytes);
  const auto file = chungs::fuzz::temp_folder().write("keyframe.bin", bytes.data(), bytes.size());
  chungs::fuzz::refusing(file, [&] {
    chungs::KeyframeImages images;
    chungs::read_keyframe_file(file, images);
  });
  return 0;
}
