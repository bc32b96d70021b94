// The PLY mesh reader (synth/ply.hpp), ascii and binary, that synthetic scenes load meshes with. It is
// the project's only PLY reader: the 3DGS PLY of `export` is written, never read back.
#include "chungs/synth/ply.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto file = chungs::fuzz::temp_folder().write("mesh.ply", data, size);
  chungs::fuzz::refusing(file, [&] { chungs::synth::read_ply(file); });
  return 0;
}
