// Trajectory files (geometry/trajectory.hpp) as `eval --gt/--est` read them: TUM, KITTI, and the
// by-content guess. The first byte picks the reader, the rest is the file.
#include "chungs/geometry/trajectory.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const auto file = chungs::fuzz::temp_folder().write("trajectory.txt", data + 1, size - 1);
  chungs::fuzz::refusing(file, [&] {
    switch (data[0] % 3) {
      case 0:
        chungs::read_tum_trajectory(file);
        break;
      case 1:
        chungs::read_kitti_trajectory(file);
        break;
      default:
        chungs::read_trajectory(file);
    }
  });
  return 0;
}
