// Chunk files (store/chunk_file.hpp), full and half precision, raw, shuffled or zstd. Both
// checksums are recomputed over the mutated bytes before the file is written, or nearly every
// input would stop at "checksum mismatch" and the decoder behind it would never be reached; the
// checksum checks themselves are a few lines the unit tests cover.
#include <vector>

#include "chungs/store/chunk_file.hpp"
#include "fuzz_input.hpp"
#include "reseal.hpp"

namespace {

// Offsets in the 72-byte header (chunk_file.hpp).
constexpr size_t kHeaderBytes = 72;
constexpr size_t kPayloadChecksumAt = 56;
constexpr size_t kHeaderChecksumAt = 64;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  chungs::fuzz::reseal(bytes, kHeaderBytes, kPayloadChecksumAt, kHeaderChecksumAt);
  const auto& tmp = chungs::fuzz::temp_folder();
  const auto file = tmp.write("chunk.bin", bytes.data(), bytes.size());
  chungs::fuzz::refusing(file, [&] {
    chungs::read_chunk_header(file);
    chungs::GaussianBlock block;
    chungs::read_chunk_file(file, block);
  });
  return 0;
}
