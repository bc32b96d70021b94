// Replica (NICE-SLAM layout) and 3DMatch: real excerpts, and damaged copies built in a TempDir.
#include <gtest/gtest.h>

#include "chungs/datasets/dataset.hpp"
#include "chungs/image/image_io.hpp"
#include "dataset_test_util.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

TEST(Replica, ReadsExcerptFromSequenceOrParentFolder) {
  CHUNGS_REQUIRE_DATA("replica_office0");
  fs::path root = test::shared_data("replica_office0");
  // Also from the images' folder itself (SEQ/results), with or without a trailing separator.
  for (const fs::path& p : {root, root / "office0", root / "office0" / "results", root / "office0" / "results" / ""}) {
    auto ds = open_dataset("replica:" + p.string());
    const auto& in = ds->info();
    EXPECT_EQ(in.kind, "replica");
    EXPECT_EQ(in.path.filename(), "office0");
    EXPECT_EQ(in.frames, 4u);
    EXPECT_EQ(in.camera.width, 1200);
    EXPECT_EQ(in.camera.height, 680);
    EXPECT_DOUBLE_EQ(in.camera.fx, 600);
    EXPECT_DOUBLE_EQ(in.camera.fy, 600);
    EXPECT_DOUBLE_EQ(in.camera.cx, 599.5);
    EXPECT_DOUBLE_EQ(in.camera.cy, 339.5);
    EXPECT_TRUE(in.has_depth);
    EXPECT_TRUE(in.has_gt);
    EXPECT_FALSE(in.has_right);
    EXPECT_TRUE(in.color);
    EXPECT_EQ(in.baseline, 0);
  }
  auto ds = open_dataset("replica:" + root.string());
  // Frame 0 takes traj.txt line 1 (translation column of the row-major 4x4).
  auto p0 = ds->gt_pose(0);
  ASSERT_TRUE(p0);
  EXPECT_NEAR(p0->t.x(), -0.3569159214564542, 1e-12);
  EXPECT_NEAR(p0->t.y(), -0.6602722315763628, 1e-12);
  EXPECT_NEAR(p0->t.z(), 0.8192365926179191, 1e-12);
  EXPECT_NEAR(ds->gt_pose(1)->t.x(), -0.3392391072404580, 1e-12);
  EXPECT_GT(gt_path_length(*ds), 0);
  EXPECT_LT(gt_path_length(*ds), 0.2);  // 3 steps of a smooth 2000-pose trajectory

  for (size_t i = 0; i < ds->size(); ++i) {
    Frame f = ds->frame(i);
    EXPECT_EQ(f.left.channels(), 3);
    ASSERT_TRUE(f.depth);
    EXPECT_TRUE(f.depth->same_size(f.left));
    double valid = 0, med = test::median_valid(*f.depth, &valid);
    EXPECT_GT(med, 0.5) << "frame " << i;
    EXPECT_LT(med, 5.0) << "frame " << i;
    EXPECT_GT(valid, 0.9);  // a rendered mesh room: nearly every pixel has depth
  }
}

TEST(ReplicaBadInput, MoreImagesThanPosesNamesTrajectory) {
  test::TempDir tmp;
  fs::path seq = tmp / "room";
  test::write_text(tmp / "cam_params.json",
                   R"({"camera": {"w": 8, "h": 6, "fx": 5.0, "fy": 5.0, "cx": 3.5, "cy": 2.5, "scale": 1000.0}})");
  for (int i = 0; i < 3; ++i) {
    write_jpeg(seq / "results" / cat("frame00000", i, ".jpg"), Image8(8, 6, 3, 100));
    write_png(seq / "results" / cat("depth00000", i, ".png"), Image16(8, 6, 1, 1500));
  }
  test::write_text(seq / "traj.txt", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 1 0 1 0 0 0 0 1 0 0 0 0 1\n");
  test::expect_error([&] { open_dataset("replica:" + tmp.path().string()); }, {"frame000002.jpg", "traj.txt", "2 lines"});

  test::write_text(seq / "traj.txt", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 1 0 1 0 0 0 0 1 0 0 0 0 1\n"
                                     "1 0 0 2 0 1 0 0 0 0 1 0 0 0 0 1\n");
  auto ds = open_dataset("replica:" + seq.string());
  EXPECT_EQ(ds->size(), 3u);
  EXPECT_FLOAT_EQ((*ds->frame(2).depth)(3, 3), 1.5f);  // scale 1000 from cam_params.json
  EXPECT_DOUBLE_EQ(gt_path_length(*ds), 2.0);

  test::write_text(tmp / "cam_params.json", R"({"camera": {"w": 8, "h": 6, "fx": -5.0, "fy": 5.0, "cx": 3.5, "cy": 2.5}})");
  test::expect_error([&] { open_dataset("replica:" + seq.string()); }, {"cam_params.json", "camera.fx"});
  test::write_text(tmp / "cam_params.json", R"({"camera": {"w": 8, )");
  test::expect_error([&] { open_dataset("replica:" + seq.string()); }, {"cam_params.json", "invalid JSON"});
}

TEST(ReplicaBadInput, MissingDepthNamesTheColourImage) {
  test::TempDir tmp;
  write_jpeg(tmp / "results" / "frame000000.jpg", Image8(1200, 680, 3, 100));
  test::write_text(tmp / "traj.txt", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n");
  test::expect_error([&] { open_dataset("replica:" + tmp.path().string()); }, {"frame000000.jpg", "depth"});
}

TEST(ThreeDMatch, ReadsExcerptWithGapsInFrameNumbers) {
  CHUNGS_REQUIRE_DATA("3dmatch_seq01");
  fs::path root = test::shared_data("3dmatch_seq01");
  for (const fs::path& p : {root, root / "seq-01"}) {
    auto ds = open_dataset("3dmatch:" + p.string());
    const auto& in = ds->info();
    EXPECT_EQ(in.kind, "3dmatch");
    EXPECT_EQ(in.frames, 5u);
    EXPECT_EQ(in.camera.width, 640);
    EXPECT_EQ(in.camera.height, 480);
    EXPECT_DOUBLE_EQ(in.camera.fx, 570.342205);
    EXPECT_DOUBLE_EQ(in.camera.fy, 570.342205);
    EXPECT_DOUBLE_EQ(in.camera.cx, 320);
    EXPECT_DOUBLE_EQ(in.camera.cy, 240);
    EXPECT_TRUE(in.has_depth);
    EXPECT_TRUE(in.has_gt);
    EXPECT_TRUE(in.color);
    EXPECT_DOUBLE_EQ(in.rate_hz, 30);
  }
  auto ds = open_dataset("3dmatch:" + root.string());
  EXPECT_DOUBLE_EQ(ds->timestamp(2), 2 / 30.0);
  EXPECT_DOUBLE_EQ(ds->timestamp(3), 116 / 30.0);
  EXPECT_DOUBLE_EQ(ds->timestamp(4), 422 / 30.0);
  auto p0 = ds->gt_pose(0);
  ASSERT_TRUE(p0);
  EXPECT_NEAR(p0->t.x(), 1.973046, 1e-9);
  EXPECT_NEAR(p0->t.y(), 1.125734, 1e-9);
  EXPECT_NEAR(p0->t.z(), 0.309820, 1e-9);
  EXPECT_NEAR(p0->rotation()(0, 0), 0.313181, 1e-3);  // from_matrix projects onto SO(3)

  for (size_t i = 0; i < ds->size(); ++i) {
    Frame f = ds->frame(i);
    EXPECT_EQ(f.left.channels(), 3);
    ASSERT_TRUE(f.depth);
    double valid = 0, med = test::median_valid(*f.depth, &valid);
    EXPECT_GT(med, 0.5) << f.source;
    EXPECT_LT(med, 5.0) << f.source;
    EXPECT_GT(valid, 0.5) << f.source;
  }
  EXPECT_NE(ds->frame(3).source.find("frame-000116.color.png"), std::string::npos);
}

TEST(ThreeDMatchBadInput, DamagedFilesAreNamed) {
  CHUNGS_REQUIRE_DATA("3dmatch_seq01");
  test::TempDir tmp;
  fs::copy(test::shared_data("3dmatch_seq01"), tmp.path(), fs::copy_options::recursive);
  fs::path seq = tmp / "seq-01";
  EXPECT_EQ(open_dataset("3dmatch:" + tmp.path().string())->size(), 5u);

  test::write_text(seq / "frame-000116.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1\n0 0 0 1\n");
  test::expect_error([&] { open_dataset("3dmatch:" + seq.string()); }, {"frame-000116.pose.txt:3", "found 3"});
  fs::remove(seq / "frame-000116.pose.txt");
  test::expect_error([&] { open_dataset("3dmatch:" + seq.string()); }, {"frame-000116.pose.txt", "does not exist"});
  fs::copy_file(test::shared_data("3dmatch_seq01") / "seq-01" / "frame-000116.pose.txt", seq / "frame-000116.pose.txt");

  fs::resize_file(seq / "frame-000002.depth.png", 100);
  auto ds = open_dataset("3dmatch:" + seq.string());
  test::expect_error([&] { ds->frame(2); }, {"frame-000002.depth.png"});

  test::write_text(tmp / "camera-intrinsics.txt", "570 0 320\n0 0 240\n0 0 1\n");
  test::expect_error([&] { open_dataset("3dmatch:" + seq.string()); }, {"camera-intrinsics.txt", "fy must be positive"});
  fs::remove(tmp / "camera-intrinsics.txt");
  test::expect_error([&] { open_dataset("3dmatch:" + seq.string()); }, {"camera-intrinsics.txt", "missing"});
}
