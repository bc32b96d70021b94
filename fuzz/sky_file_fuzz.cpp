// The sky texture's file (mapping/sky_file.hpp). When the length fits the declared texels the
// trailing checksum is recomputed, so inputs reach the value checks behind it.
#include <cstring>
#include <vector>

#include "chungs/mapping/sky_file.hpp"
#include "chungs/store/checksum.hpp"
#include "fuzz_input.hpp"

namespace {

// magic[8], width i32, height i32, axes f32[9] (sky_file.cpp), then per texel 3 colours and 3 + 3
// Adam moments as float32 and one uint32 step count, in four arrays, each chained into the
// checksum with the previous sum as the seed.
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 9 * 4;

void reseal(std::vector<uint8_t>& bytes) {
  if (bytes.size() < kHeaderBytes + 8) return;
  int32_t w = 0, h = 0;
  std::memcpy(&w, bytes.data() + 8, 4);
  std::memcpy(&h, bytes.data() + 12, 4);
  if (w <= 0 || h <= 0) return;
  const uint64_t texels = uint64_t(w) * uint64_t(h);
  if (bytes.size() != kHeaderBytes + texels * 40 + 8) return;
  const size_t parts[] = {kHeaderBytes, texels * 12, texels * 12, texels * 12, texels * 4};
  uint64_t sum = 0;
  size_t at = 0;
  for (size_t n : parts) {
    sum = chungs::xxh64(bytes.data() + at, n, sum);
    at += n;
  }
  std::memcpy(bytes.data() + at, &sum, sizeof sum);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  reseal(bytes);
  const auto file = chungs::fuzz::temp_folder().write("sky.bin", bytes.data(), bytes.size());
  chungs::fuzz::refusing(file, [&] { chungs::read_sky_file(file); });
  return 0;
}
