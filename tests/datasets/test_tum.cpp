// TUM RGB-D has no excerpt in shared/data: these tests build small sequences in the TUM layout.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "chungs/datasets/dataset.hpp"
#include "chungs/image/image_io.hpp"
#include "dataset_test_util.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

const double kRgbStamps[] = {1.00, 1.10, 1.20, 1.30};
const double kDepthStamps[] = {1.005, 1.11, 1.31};  // 1.20 has no depth within 0.02 s

std::string fixed6(double v, int digits = 6) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

// The freiburg1 camera as published (what the reader must recognise from the folder name).
Camera fr1() {
  Camera c(640, 480, 517.3, 516.5, 318.6, 255.3);
  c.dist = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  return c;
}

// A gray blob drawn on black at `centre` (pixels) in an RGB image.
Image8 blob_image(int w, int h, const Eigen::Vector2d& centre) {
  Image8 img(w, h, 3, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double r2 = std::pow(x - centre.x(), 2) + std::pow(y - centre.y(), 2);
      auto v = uint8_t(std::lround(250 * std::exp(-r2 / (2 * 2.0 * 2.0))));
      for (int c = 0; c < 3; ++c) img(x, y, c) = v;
    }
  return img;
}

// rgb images show a blob at `blob` (source pixels); depth is 1.5 m with an invalid (0) left half.
fs::path make_tum(const fs::path& root, const std::string& name, const Eigen::Vector2d& blob) {
  fs::path dir = root / name;
  std::string rgb_txt = "# color images\n# file: 'x'\n# timestamp filename\n", depth_txt = rgb_txt;
  for (double t : kRgbStamps) {
    std::string f = "rgb/" + fixed6(t) + ".png";
    write_png(dir / f, blob_image(640, 480, blob));
    rgb_txt += fixed6(t) + " " + f + "\n";
  }
  Image16 depth(640, 480, 1, 7500);
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 320; ++x) depth(x, y) = 0;
  for (double t : kDepthStamps) {
    std::string f = "depth/" + fixed6(t) + ".png";
    write_png(dir / f, depth);
    depth_txt += fixed6(t) + " " + f + "\n";
  }
  test::write_text(dir / "rgb.txt", rgb_txt);
  test::write_text(dir / "depth.txt", depth_txt);
  // 100 Hz ground truth at stamps offset by 5 ms from the frames: x = 2t, rotation t rad about z.
  std::string gt = "# timestamp tx ty tz qx qy qz qw\n";
  for (int k = 0; k < 50; ++k) {
    double t = 0.995 + 0.01 * k;
    gt += fixed6(t) + " " + fixed6(2 * t) + " 0 0 0 0 " + fixed6(std::sin(t / 2), 15) + " " + fixed6(std::cos(t / 2), 15) + "\n";
  }
  test::write_text(dir / "groundtruth.txt", gt);
  return dir;
}

Eigen::Vector2d centroid(const Image8& img, const Eigen::Vector2d& around, int radius) {
  double sx = 0, sy = 0, sw = 0;
  for (int y = int(around.y()) - radius; y <= int(around.y()) + radius; ++y)
    for (int x = int(around.x()) - radius; x <= int(around.x()) + radius; ++x) {
      double w = img(x, y, 0);
      sx += w * x, sy += w * y, sw += w;
    }
  return {sx / sw, sy / sw};
}

}  // namespace

TEST(Tum, AssociatesDepthInterpolatesGtAndScalesDepth) {
  test::TempDir tmp;
  fs::path dir = make_tum(tmp.path(), "rgbd_dataset_freiburg3_synthetic", {320, 240});
  auto ds = open_dataset("tum:" + dir.string());
  const auto& in = ds->info();
  EXPECT_EQ(in.kind, "tum");
  ASSERT_EQ(in.frames, 3u);
  EXPECT_DOUBLE_EQ(ds->timestamp(0), 1.00);
  EXPECT_DOUBLE_EQ(ds->timestamp(1), 1.10);
  EXPECT_DOUBLE_EQ(ds->timestamp(2), 1.30);
  EXPECT_DOUBLE_EQ(in.camera.fx, 535.4);
  EXPECT_DOUBLE_EQ(in.camera.fy, 539.2);
  EXPECT_DOUBLE_EQ(in.camera.cx, 320.1);
  EXPECT_DOUBLE_EQ(in.camera.cy, 247.6);
  EXPECT_TRUE(in.has_depth && in.has_gt && in.color);
  EXPECT_FALSE(in.has_right);
  // Interpolated between samples 5 ms either side; the nearest sample would be 0.02 m off.
  for (size_t i = 0; i < 3; ++i) {
    auto p = ds->gt_pose(i);
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->t.x(), 2 * ds->timestamp(i), 1e-9);
    EXPECT_NEAR(p->angle(), ds->timestamp(i), 1e-9);
  }
  EXPECT_NEAR(gt_path_length(*ds), 0.6, 1e-9);
  Frame f = ds->frame(1);
  ASSERT_TRUE(f.depth);
  EXPECT_FLOAT_EQ((*f.depth)(400, 100), 1.5f);
  EXPECT_FLOAT_EQ((*f.depth)(100, 100), 0.0f);
  EXPECT_EQ(f.left(320, 240, 0), 250);  // no distortion for freiburg3: pixels untouched
}

TEST(Tum, Freiburg1IsUndistortedConsistentlyWithTheCameraModel) {
  // A blob drawn where the distorted lens images the ray of undistorted pixel u must land on u.
  Camera cam = fr1();
  Eigen::Vector2d u(520, 400);  // far from the centre, where distortion moves pixels most
  Eigen::Vector2d xn((u.x() - cam.cx) / cam.fx, (u.y() - cam.cy) / cam.fy);
  Eigen::Vector2d xd = cam.distort(xn);
  Eigen::Vector2d src(cam.fx * xd.x() + cam.cx, cam.fy * xd.y() + cam.cy);
  ASSERT_GT((src - u).norm(), 5);  // the test means something only if distortion moves the blob

  test::TempDir tmp;
  fs::path dir = make_tum(tmp.path(), "rgbd_dataset_freiburg1_xyz", src);
  auto ds = open_dataset("tum:" + dir.string());
  const Camera& c = ds->info().camera;
  EXPECT_FALSE(c.distorted());
  EXPECT_DOUBLE_EQ(c.fx, 517.3);
  EXPECT_DOUBLE_EQ(c.cy, 255.3);
  Frame f = ds->frame(0);
  EXPECT_FALSE(f.camera.distorted());
  EXPECT_LT((centroid(f.left, u, 8) - u).norm(), 0.3);
  // Depth goes through the same map, by nearest neighbour: values stay 1.5 or 0, never blends.
  for (float d : f.depth->vec()) ASSERT_TRUE(d == 0.0f || d == 1.5f) << d;
  EXPECT_FLOAT_EQ((*f.depth)(500, 240), 1.5f);
}

TEST(Tum, UnknownFolderUsesDefaultsAndCalibOverride) {
  test::TempDir tmp;
  fs::path dir = make_tum(tmp.path(), "my_kinect", {320, 240});
  EXPECT_DOUBLE_EQ(open_dataset("tum:" + dir.string())->info().camera.fx, 525);
  test::write_text(dir / "calib.txt", "600 610 330 250\n");
  auto ds = open_dataset("tum:" + dir.string());
  EXPECT_DOUBLE_EQ(ds->info().camera.fy, 610);
  EXPECT_DOUBLE_EQ(ds->info().camera.cx, 330);
  test::write_text(dir / "calib.txt", "600 -610 330 250\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"calib.txt:1", "positive"});
}

TEST(TumBadInput, BrokenIndexAndGroundTruthNameFileAndLine) {
  test::TempDir tmp;
  fs::path dir = make_tum(tmp.path(), "rgbd_dataset_freiburg2_desk", {320, 240});
  test::write_text(dir / "groundtruth.txt", "# t tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n1.01 0 0 0 0 0 1\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"groundtruth.txt:3"});
  fs::remove(dir / "groundtruth.txt");
  EXPECT_FALSE(open_dataset("tum:" + dir.string())->info().has_gt);
  // A listed file that is not there is refused on opening, naming the line (inspect counted such a frame,
  // and a run stopped at it).
  test::write_text(dir / "depth.txt", "1.0 depth/1.005000.png\n1.1 depth/missing.png\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"depth.txt:2", "depth/missing.png", "is not a file"});
  test::write_text(dir / "depth.txt", "1.0 depth/1.005000.png\n1.1 depth\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"depth.txt:2", "is not a file"});
  test::write_text(dir / "depth.txt", "1.0 depth/1.005000.png extra\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"depth.txt:1", "expected 2 fields"});
  fs::remove(dir / "rgb.txt");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"rgb.txt", "does not exist"});
}

TEST(TumBadInput, TimestampGoingBackwardsNamesFileAndLine) {
  // Frames are mapped in the order they are listed: a stamp out of order would be mapped out of time.
  test::TempDir tmp;
  fs::path dir = make_tum(tmp.path(), "rgbd_dataset_freiburg2_desk", {320, 240});
  test::write_text(
      dir / "rgb.txt",
      "# colour\n1.000000 rgb/1.000000.png\n1.200000 rgb/1.200000.png\n1.100000 rgb/1.100000.png\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"rgb.txt:4", "1.1", "1.2"});
  test::write_text(dir / "rgb.txt", "1.000000 rgb/1.000000.png\n1.000000 rgb/1.100000.png\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"rgb.txt:2"});
  test::write_text(dir / "rgb.txt", "1.000000 rgb/1.000000.png\n");
  test::write_text(dir / "depth.txt", "1.310000 depth/1.310000.png\n1.005000 depth/1.005000.png\n");
  test::expect_error([&] { open_dataset("tum:" + dir.string()); }, {"depth.txt:2"});
}

TEST(TumBadInput, EightBitDepthIsRefusedNamingTheFile) {
  // TUM depth is 16-bit (1/5000 m); an 8-bit PNG read as such would put every surface within 5 cm.
  test::TempDir tmp;
  fs::path dir = make_tum(tmp.path(), "rgbd_dataset_freiburg2_desk", {320, 240});
  write_png(dir / "depth/1.005000.png", Image8(640, 480, 1, 200));
  auto ds = open_dataset("tum:" + dir.string());
  test::expect_error([&] { ds->frame(0); }, {"depth/1.005000.png", "16-bit"});
}
