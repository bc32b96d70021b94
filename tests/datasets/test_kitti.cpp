#include <gtest/gtest.h>

#include <random>

#include "chungs/datasets/dataset.hpp"
#include "chungs/image/image_io.hpp"
#include "dataset_test_util.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

// A tiny KITTI sequence: n random pairs (colour in image_2/3), labelled calib (fx 100, baseline 0.5 m), poses moving
// 1 m along z per frame.
void make_kitti(const fs::path& dir, int n, const std::string& left = "image_0", const std::string& right = "image_1") {
  std::mt19937 rng(3);
  int channels = left == "image_2" ? 3 : 1;
  for (int i = 0; i < n; ++i) {
    Image8 img(16, 12, channels);
    for (auto& v : img.vec()) v = uint8_t(rng());
    char name[16];
    std::snprintf(name, sizeof name, "%06d.png", i);
    write_png(dir / left / name, img);
    write_png(dir / right / name, img);
  }
  test::write_text(dir / "calib.txt",
                   "P0: 100 0 8 0 0 100 6 0 0 0 1 0\nP1: 100 0 8 -50 0 100 6 0 0 0 1 0\n"
                   "P2: 100 0 8 6 0 100 6 0 0 0 1 0\nP3: 100 0 8 -44 0 100 6 0 0 0 1 0\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  std::string poses;
  for (int i = 0; i < n; ++i) poses += cat("1 0 0 0 0 1 0 0 0 0 1 ", i, "\n");
  test::write_text(dir / "poses.txt", poses);
}

}  // namespace

TEST(Kitti, ReadsExcerptFramesCalibrationAndPoses) {
  CHUNGS_REQUIRE_DATA("kitti_seq1");
  auto ds = open_dataset("kitti:" + test::shared_data("kitti_seq1").string());
  const auto& in = ds->info();
  EXPECT_EQ(in.kind, "kitti");
  EXPECT_EQ(in.frames, 51u);
  EXPECT_EQ(in.camera.width, 1226);
  EXPECT_EQ(in.camera.height, 370);
  EXPECT_DOUBLE_EQ(in.camera.fx, 707.0912);
  EXPECT_DOUBLE_EQ(in.camera.fy, 707.0912);
  EXPECT_DOUBLE_EQ(in.camera.cx, 601.8873);
  EXPECT_DOUBLE_EQ(in.camera.cy, 183.1104);
  EXPECT_FALSE(in.camera.distorted());
  EXPECT_NEAR(in.baseline, 379.8145 / 707.0912, 1e-9);
  EXPECT_NEAR(in.baseline, 0.537, 0.001);
  EXPECT_TRUE(in.has_right);
  EXPECT_FALSE(in.has_depth);
  EXPECT_TRUE(in.has_gt);
  EXPECT_FALSE(in.color);
  EXPECT_DOUBLE_EQ(in.rate_hz, 10);
  EXPECT_NEAR(ds->timestamp(10), 1.0, 1e-12);

  auto first = ds->gt_pose(0);
  ASSERT_TRUE(first);
  EXPECT_LT(first->t.norm(), 1e-9);
  EXPECT_LT(first->angle(), 1e-9);
  // The car drives about 60 m, nearly straight ahead (+z in camera 0).
  double len = gt_path_length(*ds);
  EXPECT_GT(len, 50);
  EXPECT_LT(len, 70);
  auto last = ds->gt_pose(50);
  ASSERT_TRUE(last);
  EXPECT_GT(last->t.z(), 0.95 * last->t.norm());

  Frame f = ds->frame(50);
  EXPECT_EQ(f.index, 50u);
  EXPECT_EQ(f.left.width(), 1226);
  EXPECT_EQ(f.left.height(), 370);
  EXPECT_EQ(f.left.channels(), 1);
  ASSERT_TRUE(f.right);
  EXPECT_TRUE(f.right->same_shape(f.left));
  EXPECT_FALSE(f.depth);
  EXPECT_DOUBLE_EQ(f.baseline, in.baseline);
  EXPECT_NE(f.source.find("000050.png"), std::string::npos);
  EXPECT_THROW(ds->frame(51), Error);
  EXPECT_THROW(ds->gt_pose(51), Error);
}

// Given one of the image folders (as a file dialog or a tab completion leaves it), the sequence is read.
TEST(Kitti, AnImageFolderOpensItsSequence) {
  CHUNGS_REQUIRE_DATA("kitti_seq1");
  const fs::path seq = test::shared_data("kitti_seq1");
  for (const fs::path& p : {seq / "image_l", seq / "image_r" / ""}) {
    auto ds = open_dataset("kitti:" + p.string());
    EXPECT_EQ(ds->info().frames, 51u) << p;
    EXPECT_TRUE(ds->info().has_right) << p;
    EXPECT_TRUE(ds->gt_pose(50)) << p;
  }
}

TEST(Kitti, FindsPosesInStandardLayoutAndReadsTimes) {
  test::TempDir tmp;
  fs::path seq = tmp / "sequences" / "07";
  make_kitti(seq, 3);
  fs::rename(seq / "poses.txt", tmp / "poses_07.txt");
  fs::create_directories(tmp / "poses");
  fs::rename(tmp / "poses_07.txt", tmp / "poses" / "07.txt");
  test::write_text(seq / "times.txt", "0.0\n0.25\n0.5\n0.75\n");
  auto ds = open_dataset("kitti:" + seq.string() + "/");
  EXPECT_EQ(ds->size(), 3u);
  EXPECT_TRUE(ds->info().has_gt);
  EXPECT_NEAR(ds->gt_pose(2)->t.z(), 2.0, 1e-12);
  EXPECT_DOUBLE_EQ(ds->timestamp(2), 0.5);
  EXPECT_DOUBLE_EQ(ds->info().rate_hz, 4);
  EXPECT_DOUBLE_EQ(ds->info().baseline, 0.5);
  EXPECT_DOUBLE_EQ(gt_path_length(*ds), 2.0);
}

TEST(Kitti, ColourPairUsesP2P3AndShiftsGroundTruthToCamera2) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 2, "image_2", "image_3");
  auto ds = open_dataset("kitti:" + tmp.path().string());
  // P2 offset 6 -> camera 2 sits 0.06 m left of camera 0 (x = -0.06); P3 offset -44 -> x = 0.44.
  EXPECT_NEAR(ds->info().baseline, 0.5, 1e-12);
  EXPECT_NEAR(ds->gt_pose(0)->t.x(), -0.06, 1e-12);
  EXPECT_TRUE(ds->info().color);
}

TEST(Kitti, AcceptsUnlabelledCalibWithoutTrailingNewline) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 2, "image_l", "image_r");
  test::write_text(tmp / "calib.txt", "100 0 8 0 0 100 6 0 0 0 1 0\n100 0 8 -30 0 100 6 0 0 0 1 0");
  auto ds = open_dataset("kitti:" + tmp.path().string());
  EXPECT_NEAR(ds->info().baseline, 0.3, 1e-12);
  EXPECT_FALSE(ds->info().color);
}

TEST(Kitti, WithoutPosesOrTimesHasNoGtAndTenHertz) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 3);
  fs::remove(tmp / "poses.txt");
  auto ds = open_dataset("kitti:" + tmp.path().string());
  EXPECT_FALSE(ds->info().has_gt);
  EXPECT_FALSE(ds->gt_pose(1));
  EXPECT_DOUBLE_EQ(ds->timestamp(2), 0.2);
  EXPECT_DOUBLE_EQ(gt_path_length(*ds), 0);
}

TEST(KittiBadInput, MissingCalibNamesTheFile) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 2);
  fs::remove(tmp / "calib.txt");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"calib.txt", "does not exist"});
}

TEST(KittiBadInput, NonPositiveBaselineNamesCalibLine) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 2);
  test::write_text(tmp / "calib.txt", "P0: 100 0 8 0 0 100 6 0 0 0 1 0\nP1: 100 0 8 50 0 100 6 0 0 0 1 0\n");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"calib.txt:2", "baseline"});
}

TEST(KittiBadInput, CalibWithNaNOrShortLineNamesLine) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 2);
  test::write_text(tmp / "calib.txt", "P0: 100 0 8 0 0 nan 6 0 0 0 1 0\nP1: 100 0 8 -50 0 100 6 0 0 0 1 0\n");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"calib.txt:1", "nan"});
  test::write_text(tmp / "calib.txt", "P0: 100 0 8 0 0 100 6 0 0 0 1 0\nP1: 100 0 8 -50 0 100 6 0 0 0 1\n");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"calib.txt:2", "12 numbers"});
}

TEST(KittiBadInput, PosesWithWrongFieldCountNameFileAndLine) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 4);
  test::write_text(tmp / "poses.txt",
                   "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 1\n1 0 0 0 0 1 0 0 0 0 1\n1 0 0 0 0 1 0 0 0 0 1 3\n");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"poses.txt:3", "11"});
}

TEST(KittiBadInput, FewerPosesThanImagesIsAnError) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 4);
  test::write_text(tmp / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"poses.txt", "1 poses for 4 images"});
}

// An excerpt from the start of a sequence beside its whole pose file: taken, with a warning that says so
// (a folder that lost its last images looks the same).
TEST(KittiBadInput, MorePosesThanImagesAreTakenFromTheStartWithAWarning) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 4);
  std::string poses;
  for (int i = 0; i < 6; ++i) poses += "1 0 0 0 0 1 0 0 0 0 1 " + std::to_string(i) + "\n";
  test::write_text(tmp / "poses.txt", poses);
  testing::internal::CaptureStderr();
  const auto ds = open_dataset("kitti:" + tmp.path().string());
  const std::string said = testing::internal::GetCapturedStderr();
  EXPECT_NE(said.find("6 poses for 4 images"), std::string::npos) << said;
  ASSERT_EQ(ds->size(), 4u);
  ASSERT_TRUE(ds->gt_pose(3).has_value());
  EXPECT_NEAR(ds->gt_pose(3)->t.z(), 3.0, 1e-9);
}

TEST(KittiBadInput, LeftRightCountMismatchNamesFolders) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 3);
  fs::remove(tmp / "image_1" / "000002.png");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"image_0", "image_1", "3", "2"});
}

TEST(KittiBadInput, TruncatedPngFailsWhenThatFrameIsRead) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 3);
  fs::path bad = tmp / "image_1" / "000001.png";
  fs::resize_file(bad, fs::file_size(bad) / 2);
  auto ds = open_dataset("kitti:" + tmp.path().string());
  EXPECT_NO_THROW(ds->frame(0));
  test::expect_error([&] { ds->frame(1); }, {"image_1/000001.png"});
}

TEST(KittiBadInput, CorruptFirstImageFailsAtOpen) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 2);
  test::write_text(tmp / "image_0" / "000000.png", "\x89PNG\r\n\x1a\n garbage that is not a PNG stream");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); }, {"image_0/000000.png"});
}

TEST(KittiBadInput, ImageOfOtherSizeNamesTheFile) {
  test::TempDir tmp;
  make_kitti(tmp.path(), 2);
  write_png(tmp / "image_0" / "000001.png", Image8(20, 12, 1));
  auto ds = open_dataset("kitti:" + tmp.path().string());
  test::expect_error([&] { ds->frame(1); }, {"image_0/000001.png", "20x12", "16x12"});
}

TEST(KittiBadInput, PairWhoseCamerasDifferIsRefusedNamingCalibAndBothValues) {
  // A rectified pair shares one camera matrix: with P1's fx taken for P0's, disparities would be
  // turned into depth with the wrong focal length and baseline, silently.
  test::TempDir tmp;
  make_kitti(tmp.path(), 2);
  test::write_text(tmp / "calib.txt", "P0: 100 0 8 0 0 100 6 0 0 0 1 0\nP1: 120 0 8 -60 0 100 6 0 0 0 1 0\n");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); },
                     {"calib.txt:2", "fx", "120", "100"});
  test::write_text(tmp / "calib.txt",
                   "P0: 100 0 8 0 0 100 6 0 0 0 1 0\nP1: 100 0 8 -50 0 100 7.5 0 0 0 1 0\n");
  test::expect_error([&] { open_dataset("kitti:" + tmp.path().string()); },
                     {"calib.txt:2", "cy", "7.5", "6"});
}
