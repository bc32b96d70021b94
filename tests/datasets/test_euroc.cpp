#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "chungs/common/text_file.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/image/image_io.hpp"
#include "dataset_test_util.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

std::string euroc_spec() { return "euroc:" + test::shared_data("euroc_v101_micro").string(); }

// A writable copy of the excerpt's text files, with the image folders linked, for damaging.
void copy_euroc(const fs::path& dst) {
  fs::path src = test::shared_data("euroc_v101_micro");
  for (const char* cam : {"cam0", "cam1"}) {
    fs::create_directories(dst / "mav0" / cam);
    for (const char* f : {"sensor.yaml", "data.csv"}) fs::copy_file(src / "mav0" / cam / f, dst / "mav0" / cam / f);
    fs::create_directory_symlink(src / "mav0" / cam / "data", dst / "mav0" / cam / "data");
  }
}

// Normalised cross-correlation of a w x h patch of a at (ax, ay) with b at (bx, by).
double ncc(const Image8& a, int ax, int ay, const Image8& b, int bx, int by, int w, int h) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double u = a(ax + x, ay + y), v = b(bx + x, by + y);
      sa += u, sb += v, saa += u * u, sbb += v * v, sab += u * v;
    }
  double n = double(w) * h;
  double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  if (va <= 0 || vb <= 0) return -1;
  return (sab - sa * sb / n) / std::sqrt(va * vb);
}

struct RowCheck {
  int patches = 0;         // textured patches that matched confidently
  int on_row = 0;          // of those, best vertical offset within +-1 row
  double mean_abs_dy = 0;  // over the confident patches
};

// For textured patches of the left image, searches the right image over disparities 0..max_disp and
// vertical offsets -max_dy..max_dy; in a rectified pair the best match lies on the same row.
RowCheck row_alignment(const Image8& left, const Image8& right, int max_dy) {
  const int w = 24, h = 16, max_disp = 80;
  RowCheck rc;
  for (int y0 = max_dy + 20; y0 + h + max_dy + 20 < left.height(); y0 += 36)
    for (int x0 = max_disp + 40; x0 + w + 40 < left.width(); x0 += 48) {
      double mean = 0, var = 0;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) mean += left(x0 + x, y0 + y);
      mean /= w * h;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) var += std::pow(left(x0 + x, y0 + y) - mean, 2);
      if (std::sqrt(var / (w * h)) < 12) continue;  // flat patches match anywhere
      double best = -2;
      int best_dy = 0;
      for (int dy = -max_dy; dy <= max_dy; ++dy)
        for (int d = 0; d <= max_disp; ++d) {
          double s = ncc(left, x0, y0, right, x0 - d, y0 + dy, w, h);
          if (s > best) best = s, best_dy = dy;
        }
      if (best < 0.9) continue;
      ++rc.patches;
      rc.on_row += std::abs(best_dy) <= 1;
      rc.mean_abs_dy += std::abs(best_dy);
    }
  if (rc.patches) rc.mean_abs_dy /= rc.patches;
  return rc;
}

}  // namespace

TEST(Euroc, ReadsExcerptAndRectifiesStereo) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  auto ds = open_dataset(euroc_spec());
  const auto& in = ds->info();
  EXPECT_EQ(in.kind, "euroc");
  EXPECT_EQ(in.frames, 95u);  // cam1's data.csv lists 4 more stamps than cam0's; they have no partner
  EXPECT_EQ(in.camera.width, 752);
  EXPECT_EQ(in.camera.height, 480);
  EXPECT_FALSE(in.camera.distorted());
  // Rectification keeps a focal length of the raw one's order (raw 458 px; 436 px measured with
  // OpenCV 4.6, alpha 0).
  EXPECT_GT(in.camera.fx, 400);
  EXPECT_LT(in.camera.fx, 480);
  EXPECT_DOUBLE_EQ(in.camera.fx, in.camera.fy);
  EXPECT_NEAR(in.baseline, 0.110, 0.002);
  EXPECT_TRUE(in.has_right);
  EXPECT_TRUE(in.has_gt);
  EXPECT_FALSE(in.color);
  EXPECT_DOUBLE_EQ(in.rate_hz, 20);
  EXPECT_NEAR(ds->timestamp(0), 1403715273.262142976, 1e-6);
  EXPECT_NEAR(ds->timestamp(1) - ds->timestamp(0), 0.05, 1e-6);

  Frame f = ds->frame(0);
  EXPECT_EQ(f.left.width(), 752);
  EXPECT_EQ(f.left.channels(), 1);
  ASSERT_TRUE(f.right);
  EXPECT_TRUE(f.right->same_shape(f.left));
  EXPECT_DOUBLE_EQ(f.camera.fx, in.camera.fx);
}

TEST(Euroc, RectifiedPairsMatchAlongRowsUnlikeRawOnes) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  auto ds = open_dataset(euroc_spec());
  Frame f = ds->frame(40);
  RowCheck rect = row_alignment(f.left, *f.right, 6);
  std::printf("rectified: %d of %d patches on their row, mean |dy| %.2f\n", rect.on_row, rect.patches, rect.mean_abs_dy);
  EXPECT_GE(rect.patches, 15);
  EXPECT_GE(rect.on_row, rect.patches * 9 / 10) << rect.on_row << " of " << rect.patches;
  EXPECT_LT(rect.mean_abs_dy, 0.5);

  // The same check on the unrectified files shows why rectification matters (the raw principal
  // points alone differ by 7 rows): this is what the check catches when rectification is wrong.
  fs::path mav = test::shared_data("euroc_v101_micro") / "mav0";
  std::string name = fs::path(f.source).filename().string();
  Image8 raw_l = read_image8(mav / "cam0" / "data" / name);
  Image8 raw_r = read_image8(mav / "cam1" / "data" / name);
  RowCheck raw = row_alignment(raw_l, raw_r, 12);
  std::printf("raw: %d of %d patches on their row, mean |dy| %.2f\n", raw.on_row, raw.patches, raw.mean_abs_dy);
  EXPECT_GE(raw.patches, 10);
  EXPECT_LT(raw.on_row, raw.patches / 2) << raw.on_row << " of " << raw.patches;
  EXPECT_GT(raw.mean_abs_dy, 3);
}

TEST(Euroc, GroundTruthIsInRectifiedCameraAndStill) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  auto ds = open_dataset(euroc_spec());
  auto p0 = ds->gt_pose(0);
  ASSERT_TRUE(p0);
  double max_move = 0;
  for (size_t i = 0; i < ds->size(); ++i) {
    auto p = ds->gt_pose(i);
    ASSERT_TRUE(p) << "frame " << i;
    max_move = std::max(max_move, (p->t - p0->t).norm());
  }
  EXPECT_LT(max_move, 0.01);
  EXPECT_LT(gt_path_length(*ds), 0.05);

  // Body pose at the first frame from the TUM file's first line (same stamp to 3 us), then
  // body -> cam0 (T_BS) by hand: the camera centre is independent of the rectifying rotation.
  Eigen::Quaterniond qb(0.069433, -0.824237, -0.106942, -0.551702);
  SE3 body(qb.normalized(), Eigen::Vector3d(0.878895, 2.183400, 0.948427));
  Eigen::Vector3d t_bs(-0.0216401454975, -0.064676986768, 0.00981073058949);
  EXPECT_LT((p0->t - body * t_bs).norm(), 1e-4);
  // The rectified optical axis differs from the raw cam0 one by the small rectifying rotation.
  Eigen::Matrix3d R_bs;
  R_bs << 0.0148655429818, -0.999880929698, 0.00414029679422, 0.999557249008, 0.0149672133247, 0.025715529948,
      -0.0257744366974, 0.00375618835797, 0.999660727178;
  Eigen::Vector3d raw_axis = body.rotation() * R_bs.col(2);
  Eigen::Vector3d rect_axis = p0->rotation().col(2);
  double angle = std::acos(std::min(1.0, raw_axis.dot(rect_axis)));
  EXPECT_LT(angle, 0.05);
  EXPECT_GT(angle, 1e-4);
  // In the rectified left camera the right camera's centre lies on the x axis, one baseline away:
  // this pins the rectifying rotation's direction (its transpose would tilt the baseline).
  Eigen::Vector3d t_bs1(-0.0198435579556, 0.0453689425024, 0.00786212447038);
  Eigen::Vector3d b = p0->rotation().transpose() * (body * t_bs1 - p0->t);
  std::printf("baseline in rectified camera: %.6f %.6f %.6f; raw-to-rectified axis angle %.5f rad\n", b.x(), b.y(),
              b.z(), angle);
  EXPECT_NEAR(b.x(), ds->info().baseline, 1e-4);
  EXPECT_NEAR(b.y(), 0, 1e-4);
  EXPECT_NEAR(b.z(), 0, 1e-4);
}

// Given mav0/ itself (as many tools are), the ground truth in the sequence folder above it is found;
// given one camera's folder, the error says which folder to give.
TEST(Euroc, TheMav0FolderFindsTheSequencesGroundTruthAndACameraFolderIsNamed) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  const auto whole = open_dataset(euroc_spec());
  for (const std::string tail : {"/mav0", "/mav0/"}) {
    const auto mav = open_dataset(euroc_spec() + tail);
    ASSERT_EQ(mav->size(), whole->size()) << tail;
    for (size_t i : {size_t(0), whole->size() - 1}) {
      ASSERT_TRUE(mav->gt_pose(i)) << tail << " frame " << i;
      EXPECT_LT((mav->gt_pose(i)->t - whole->gt_pose(i)->t).norm(), 1e-12);
    }
  }
  try {
    open_dataset(euroc_spec() + "/mav0/cam0");
    ADD_FAILURE() << "a camera folder was opened";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is one camera's folder: give the EuRoC sequence folder"), std::string::npos)
        << e.what();
  }
}

TEST(EurocBadInput, MissingSensorYamlAndBrokenCsvNameFiles) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  test::TempDir tmp;
  copy_euroc(tmp.path());
  EXPECT_EQ(open_dataset("euroc:" + tmp.path().string())->size(), 95u);
  fs::remove(tmp / "mav0" / "cam1" / "sensor.yaml");
  test::expect_error([&] { open_dataset("euroc:" + tmp.path().string()); }, {"cam1/sensor.yaml"});
  fs::copy_file(test::shared_data("euroc_v101_micro") / "mav0" / "cam0" / "sensor.yaml", tmp / "mav0" / "cam1" / "sensor.yaml");
  test::write_text(tmp / "mav0" / "cam0" / "data.csv", "#timestamp [ns],filename\n1403715273262142976,a.png\n12x,b.png\n");
  test::expect_error([&] { open_dataset("euroc:" + tmp.path().string()); }, {"cam0/data.csv:3", "12x"});
}

TEST(EurocBadInput, MalformedYamlNamesFileAndLine) {
  CHUNGS_REQUIRE_DATA("euroc_v101_micro");
  test::TempDir tmp;
  copy_euroc(tmp.path());
  fs::path y = tmp / "mav0" / "cam0" / "sensor.yaml";
  std::string text = read_file_text(y);
  text.replace(text.find("intrinsics: ["), 13, "intrinsics: [[");
  test::write_text(y, text);
  test::expect_error([&] { open_dataset("euroc:" + tmp.path().string()); }, {"cam0/sensor.yaml:"});
  text = read_file_text(tmp / "mav0" / "cam1" / "sensor.yaml");
  text.replace(text.find("intrinsics: ["), 13, "intrinsics: [-");
  test::write_text(y, text);
  test::expect_error([&] { open_dataset("euroc:" + tmp.path().string()); }, {"cam0/sensor.yaml", "fu must be positive"});
}
