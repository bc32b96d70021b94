// The 3DMatch reader's text files (datasets/threedmatch_reader.cpp): camera-intrinsics.txt and a
// frame's pose, in a two-frame RGB-D sequence.
#include "chungs/datasets/readers.hpp"
#include "dataset_skeleton.hpp"

namespace {

const char* const kPose =
    " 1.0 0.0 0.0 0.0\n"
    " 0.0 1.0 0.0 0.0\n"
    " 0.0 0.0 1.0 0.0\n"
    " 0.0 0.0 0.0 1.0\n";

const chungs::fuzz::DatasetSkeleton& skeleton() {
  static const chungs::fuzz::DatasetSkeleton s(
      "3dmatch",
      {{"camera-intrinsics.txt", " 5.7e+00\t 0.0\t 4.0\n 0.0\t 5.7e+00\t 3.0\n 0.0\t 0.0\t 1.0\n"},
       {"seq-01/frame-000000.pose.txt", kPose},
       {"seq-01/frame-000002.pose.txt", kPose}},
      [](const chungs::fuzz::fs::path& root) {
        for (const char* n : {"000000", "000002"}) {
          const std::string stem = std::string("frame-") + n;
          chungs::fuzz::write_rgb(root / "seq-01" / (stem + ".color.png"));
          chungs::fuzz::write_depth(root / "seq-01" / (stem + ".depth.png"));
        }
      });
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  skeleton().run(data, size, [](const auto& root) { return chungs::ds::open_3dmatch(root); });
  return 0;
}
