// The TUM RGB-D reader's text files (datasets/tum_reader.cpp): rgb.txt, depth.txt,
// groundtruth.txt and the optional calib.txt, in a two-frame sequence.
#include "chungs/datasets/readers.hpp"
#include "dataset_skeleton.hpp"

namespace {

const chungs::fuzz::DatasetSkeleton& skeleton() {
  static const chungs::fuzz::DatasetSkeleton s(
      "tum",
      {{"rgb.txt", "# timestamp filename\n1305031102.175304 rgb/0.png\n1305031102.211214 rgb/1.png\n"},
       {"depth.txt", "# timestamp filename\n1305031102.160407 depth/0.png\n1305031102.226738 depth/1.png\n"},
       {"groundtruth.txt",
        "# timestamp tx ty tz qx qy qz qw\n"
        "1305031102.1758 1.34 0.62 1.66 0.66 0.61 -0.29 -0.33\n"
        "1305031102.2158 1.33 0.63 1.65 0.66 0.61 -0.29 -0.33\n"},
       {"calib.txt", "517.3 516.5 318.6 255.3 0.2624 -0.9531 -0.0054 0.0026 1.1633\n"}},
      [](const chungs::fuzz::fs::path& root) {
        for (const char* name : {"0.png", "1.png"}) {
          chungs::fuzz::write_rgb(root / "rgb" / name);
          chungs::fuzz::write_depth(root / "depth" / name);
        }
      });
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  skeleton().run(data, size, [](const auto& root) { return chungs::ds::open_tum(root); });
  return 0;
}
