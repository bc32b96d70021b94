// PNG and JPEG decoding through the project's own libpng/libjpeg path (image/image_io.hpp), as
// colour images and as 16-bit depth maps. The readers take a path, so the input goes through a file.
#include "chungs/image/image_io.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto file = chungs::fuzz::temp_folder().write("image", data, size);
  chungs::fuzz::refusing(file, [&] { chungs::read_image8(file); });
  chungs::fuzz::refusing(file, [&] { chungs::read_png16(file); });
  return 0;
}
