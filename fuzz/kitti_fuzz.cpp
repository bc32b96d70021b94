// The KITTI reader's text files (datasets/kitti_reader.cpp): calib.txt, times.txt, poses.txt, in
// a two-frame grey stereo sequence.
#include "chungs/datasets/readers.hpp"
#include "dataset_skeleton.hpp"

namespace {

const chungs::fuzz::DatasetSkeleton& skeleton() {
  static const chungs::fuzz::DatasetSkeleton s(
      "kitti",
      {{"calib.txt",
        "P0: 7.0e+02 0 4.0 0 0 7.0e+02 3.0 0 0 0 1 0\n"
        "P1: 7.0e+02 0 4.0 -3.8e+02 0 7.0e+02 3.0 0 0 0 1 0\n"
        "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n"},
       {"times.txt", "0.0\n0.1\n"},
       {"poses.txt",
        "1 0 0 0 0 1 0 0 0 0 1 0\n"
        "1 0 0 0 0 1 0 0 0 0 1 0.8\n"}},
      [](const chungs::fuzz::fs::path& root) {
        for (const char* side : {"image_0", "image_1"})
          for (const char* name : {"000000.png", "000001.png"}) chungs::fuzz::write_gray(root / side / name);
      });
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  skeleton().run(data, size, [](const auto& root) { return chungs::ds::open_kitti(root); });
  return 0;
}
