// Image sides read as numbers from calibration files (Replica's cam_params.json, EuRoC's
// sensor.yaml) are refused beyond what an image may hold, naming the file, the key and the value,
// before they become ints: converting a larger double to int is undefined behaviour, which the
// EuRoC and Replica fuzz targets caught (fuzz/corpus/{euroc,replica}/*_side_beyond_int).
#include <gtest/gtest.h>

#include "chungs/common/text_file.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/image/image_io.hpp"
#include "dataset_test_util.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

TEST(ReplicaBadInput, ImageSideBeyondAnImageIsRefusedNamingKeyAndValue) {
  test::TempDir tmp;
  for (int i = 0; i < 2; ++i) {
    write_jpeg(tmp / "results" / cat("frame00000", i, ".jpg"), Image8(8, 6, 3, 100));
    write_png(tmp / "results" / cat("depth00000", i, ".png"), Image16(8, 6, 1, 1500));
  }
  test::write_text(tmp / "traj.txt", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 1 0 1 0 0 0 0 1 0 0 0 0 1\n");
  const std::string spec = "replica:" + tmp.path().string();
  // Beyond any int, beyond an int's range as a whole number, and an int but more than an image holds.
  for (const char* w : {"1e300", "3000000000", "100000000"}) {
    test::write_text(
        tmp / "cam_params.json",
        cat(R"({"camera": {"w": )", w, R"(, "h": 6, "fx": 5.0, "fy": 5.0, "cx": 3.5, "cy": 2.5}})"));
    test::expect_error([&] { open_dataset(spec); }, {"cam_params.json", "camera.w", cat(std::stod(w))});
  }
  test::write_text(tmp / "cam_params.json",
                   R"({"camera": {"w": 8, "h": 6.5, "fx": 5.0, "fy": 5.0, "cx": 3.5, "cy": 2.5}})");
  test::expect_error([&] { open_dataset(spec); }, {"cam_params.json", "camera.h", "6.5"});
  test::write_text(tmp / "cam_params.json",
                   R"({"camera": {"w": 8, "h": 6, "fx": 5.0, "fy": 5.0, "cx": 3.5, "cy": 2.5}})");
  EXPECT_EQ(open_dataset(spec)->info().camera.width, 8);
}

TEST(EurocBadInput, ResolutionBeyondAnImageIsRefusedNamingKeyAndValue) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  test::TempDir tmp;
  const fs::path src = test::shared_data("euroc_v101_micro");
  for (const char* cam : {"cam0", "cam1"}) {
    fs::create_directories(tmp / "mav0" / cam);
    for (const char* f : {"sensor.yaml", "data.csv"})
      fs::copy_file(src / "mav0" / cam / f, tmp / "mav0" / cam / f);
    fs::create_directory_symlink(src / "mav0" / cam / "data", tmp / "mav0" / cam / "data");
  }
  const fs::path yaml = tmp / "mav0" / "cam0" / "sensor.yaml";
  const std::string text = read_file_text(yaml);
  const size_t at = text.find("resolution: [752, 480]");
  ASSERT_NE(at, std::string::npos);
  for (const char* width : {"8e20", "4294967304"}) {
    std::string damaged = text;
    damaged.replace(at, 22, cat("resolution: [", width, ", 480]"));
    test::write_text(yaml, damaged);
    test::expect_error([&] { open_dataset("euroc:" + tmp.path().string()); },
                       {"cam0/sensor.yaml", "resolution width", cat(std::stod(width))});
  }
}
