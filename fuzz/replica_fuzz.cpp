// The Replica reader's text files (datasets/replica_reader.cpp): traj.txt and cam_params.json, in
// a two-frame RGB-D sequence.
#include "chungs/datasets/readers.hpp"
#include "dataset_skeleton.hpp"

namespace {

const chungs::fuzz::DatasetSkeleton& skeleton() {
  static const chungs::fuzz::DatasetSkeleton s(
      "replica/office0",
      {{"traj.txt",
        "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n"
        "0.9 -0.3 0.3 -0.35 -0.42 -0.63 0.65 -0.66 0 -0.71 -0.69 0.8 0 0 0 1\n"},
       {"cam_params.json",
        R"({"camera": {"w": 8, "h": 6, "fx": 4.0, "fy": 4.0, "cx": 3.5, "cy": 2.5, "scale": 6553.5}})"
        "\n"}},
      [](const chungs::fuzz::fs::path& root) {
        for (const char* n : {"000000", "000001"}) {
          chungs::fuzz::write_rgb(root / "results" / (std::string("frame") + n + ".jpg"));
          chungs::fuzz::write_depth(root / "results" / (std::string("depth") + n + ".png"));
        }
      });
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  skeleton().run(data, size, [](const auto& root) { return chungs::ds::open_replica(root); });
  return 0;
}
