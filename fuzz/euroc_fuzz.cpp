// The EuRoC reader's text files (datasets/euroc_reader.cpp): each camera's sensor.yaml and
// data.csv, and the ground-truth csv, in a two-frame stereo sequence.
#include "chungs/datasets/readers.hpp"
#include "dataset_skeleton.hpp"

namespace {

// Both cameras share intrinsics; cam1 sits 0.11 m along cam0's x axis, as on the MAV.
std::string sensor(const char* x) {
  return std::string(
             "%YAML:1.0\n"
             "sensor_type: camera\n"
             "T_BS:\n"
             "  cols: 4\n"
             "  rows: 4\n"
             "  data: [0.0, -1.0, 0.0, ") +
         x +
         ",\n"
         "         1.0, 0.0, 0.0, -0.06,\n"
         "         0.0, 0.0, 1.0, 0.01,\n"
         "         0.0, 0.0, 0.0, 1.0]\n"
         "rate_hz: 20\n"
         "resolution: [8, 6]\n"
         "camera_model: pinhole\n"
         "intrinsics: [4.6, 4.6, 3.7, 2.5]\n"
         "distortion_model: radial-tangential\n"
         "distortion_coefficients: [-0.28, 0.074, 0.0002, 1.8e-05]\n";
}

const char* const kData = "#timestamp [ns],filename\n1403715273262142976,a.png\n1403715273312143104,b.png\n";

const chungs::fuzz::DatasetSkeleton& skeleton() {
  static const chungs::fuzz::DatasetSkeleton s(
      "euroc",
      {{"mav0/cam0/sensor.yaml", sensor("-0.02")},
       {"mav0/cam0/data.csv", kData},
       {"mav0/cam1/sensor.yaml", sensor("0.09")},
       {"mav0/cam1/data.csv", kData},
       {"mav0/state_groundtruth_estimate0/data.csv",
        "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n"
        "1403715273262142976,0.878,2.183,0.948,0.069,-0.824,-0.106,-0.551\n"
        "1403715273312143104,0.879,2.184,0.947,0.069,-0.824,-0.106,-0.551\n"}},
      [](const chungs::fuzz::fs::path& root) {
        for (const char* cam : {"cam0", "cam1"})
          for (const char* name : {"a.png", "b.png"}) chungs::fuzz::write_gray(root / "mav0" / cam / "data" / name);
      });
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  skeleton().run(data, size, [](const auto& root) { return chungs::ds::open_euroc(root); });
  return 0;
}
