// The map folder's keyframe list (mapping/map_state.hpp): one line of 18 numbers per keyframe,
// read back by `run --resume` and by the render and eval commands.
#include "chungs/mapping/map_state.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto file = chungs::fuzz::temp_folder().write("keyframes.txt", data, size);
  chungs::fuzz::refusing(file, [&] { chungs::read_keyframe_records(file); });
  return 0;
}
