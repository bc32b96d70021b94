// Keyframe files (store/keyframe_file.hpp): colour and optional depth, raw or zstd. Both
// checksums are recomputed over the mutated bytes so inputs reach the shape checks and the
// decompression behind them.
#include <vector>

#include "chungs/store/keyframe_file.hpp"
#include "fuzz_input.hpp"
#include "reseal.hpp"

namespace {

// Offsets in the 88-byte header (keyframe_file.cpp).
constexpr size_t kHeaderBytes = 88;
constexpr size_t kPayloadChecksumAt = 72;
constexpr size_t kHeaderChecksumAt = 80;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  chungs::fuzz::reseal(bytes, kHeaderBytes, kPayloadChecksumAt, kHeaderChecksumAt);
  const auto file = chungs::fuzz::temp_folder().write("keyframe.bin", bytes.data(), bytes.size());
  chungs::fuzz::refusing(file, [&] {
    chungs::KeyframeImages images;
    chungs::read_keyframe_file(file, images);
  });
  return 0;
}
