// The street world's determinism and loops on a short route, and the raw files of both layouts
// parsed back with the image and trajectory readers.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "chungs/geometry/trajectory.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/sequence.hpp"
#include "chungs/synth/street.hpp"
#include "test_support.hpp"

namespace chungs::synth {
namespace {
namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::string> lines(const fs::path& p, bool skip_comments = true) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);)
    if (!l.empty() && !(skip_comments && l[0] == '#')) out.push_back(l);
  return out;
}

}  // namespace

TEST(Street, ShortRouteAlreadyClosesALoop) {
  StreetOptions o;
  o.length_m = 200;  // one lap of the first block is ~180 m
  const auto traj = street_trajectory(o);
  ASSERT_EQ(traj.size(), 201u);
  o.length_m = 3000;  // long routes turn often; the rounded corners must not make them short
  EXPECT_EQ(street_trajectory(o).size(), 3001u);
  bool revisit = false;
  for (size_t i = 0; i < traj.size() && !revisit; ++i) {
    bool left = false;
    for (size_t j = i + 1; j < traj.size() && !revisit; ++j) {
      const double d = (traj.poses[j].t - traj.poses[i].t).norm();
      left |= d > 50;
      revisit = left && d < 5;
    }
  }
  EXPECT_TRUE(revisit);
  // Camera 1.65 m up, looking (nearly) horizontally: optical axis z has a small world-z component.
  for (const SE3& p : traj.poses) {
    EXPECT_NEAR(p.t.z(), 1.65, 0.05);
    EXPECT_LT(std::abs(p.rotation().col(2).z()), 0.05);
  }
}

TEST(Street, BlocksAndFramesDependOnlyOnTheSeed) {
  StreetOptions o;
  o.seed = 11;
  // A block built alone equals the same block built after others (lazy order does not matter).
  StreetWorld w1(o), w2(o);
  w2.block(3, -2);
  w2.block(0, 0);
  const Mesh& a = w1.block(0, 0);
  const Mesh& b = w2.block(0, 0);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_EQ(0, std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(a.vertices[0])));
  StreetOptions other = o;
  other.seed = 12;
  const Mesh c = build_street_block(other, 0, 0);
  EXPECT_TRUE(c.vertices.size() != a.vertices.size() ||
              std::memcmp(a.vertices.data(), c.vertices.data(), a.vertices.size() * sizeof(a.vertices[0])) != 0);

  o.length_m = 40;
  const auto traj = street_trajectory(o, 3);
  test::TempDir dir;
  for (const char* name : {"a", "b"}) {
    StreetWorld world(o);
    SequenceOptions so;
    so.layout = Layout::Kitti;
    so.baseline = kKittiBaseline;
    render_sequence(world, traj, kitti_camera(200, 60), so, dir / name);
  }
  size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir / "a")) {
    if (!e.is_regular_file()) continue;
    ++files;
    const fs::path rel = fs::relative(e.path(), dir / "a");
    EXPECT_EQ(slurp(e.path()), slurp(dir / "b" / rel)) << rel;
  }
  EXPECT_EQ(files, 3u * 3 + 4);  // image_2, image_3, depth per frame; calib, times, poses, camera.txt
}

TEST(Writers, KittiFilesParseBackExactly) {
  test::TempDir dir;
  StreetOptions o;
  o.length_m = 30;
  const auto traj = street_trajectory(o, 4);
  StreetWorld world(o);
  const Camera cam = kitti_camera(160, 48);
  SequenceOptions so;
  so.layout = Layout::Kitti;
  so.baseline = 0.54;
  render_sequence(world, traj, cam, so, dir.path());

  const auto calib = lines(dir / "calib.txt");
  ASSERT_EQ(calib.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    std::istringstream ls(calib[i]);
    std::string tag;
    double P[12];
    ls >> tag;
    for (double& v : P) ls >> v;
    ASSERT_TRUE(ls) << calib[i];
    const char want[4] = {'P', char('0' + i), ':', 0};
    EXPECT_EQ(tag, want);
    // 13 significant digits, as KITTI's own files.
    EXPECT_NEAR(P[0], cam.fx, 1e-10 * cam.fx);
    EXPECT_NEAR(P[5], cam.fy, 1e-10 * cam.fy);
    EXPECT_NEAR(P[2], cam.cx, 1e-10 * cam.cx);
    EXPECT_NEAR(P[6], cam.cy, 1e-10 * cam.cy);
    EXPECT_NEAR(P[3], (i == 1 || i == 3) ? -cam.fx * 0.54 : 0.0, 1e-9);
  }
  const auto times = lines(dir / "times.txt");
  ASSERT_EQ(times.size(), 4u);
  EXPECT_NEAR(std::stod(times[3]), 0.3, 1e-9);
  const Trajectory back = read_kitti_trajectory(dir / "poses.txt");
  ASSERT_EQ(back.size(), 4u);
  for (size_t i = 0; i < 4; ++i) EXPECT_LT((back.poses[i].matrix() - traj.poses[i].matrix()).norm(), 1e-9);

  RenderedFrame ref;
  Rasterizer r;
  render_frame(r, world, cam, traj.poses[2], 0.54, RenderOptions{}, ref);
  const Image8 left = read_image8(dir / "image_2" / "000002.png"), right = read_image8(dir / "image_3" / "000002.png");
  EXPECT_EQ(left.channels(), 3);
  EXPECT_EQ(left.vec(), ref.left.vec());
  EXPECT_EQ(right.vec(), ref.right.vec());
  EXPECT_NE(left.vec(), right.vec());
  const Image16 depth = read_png16(dir / "depth" / "000002.png");
  size_t valid = 0;
  for (size_t i = 0; i < depth.pixels(); ++i) {
    if (ref.depth.data()[i] <= 0 || ref.depth.data()[i] * 256 > 65535) continue;
    ASSERT_NEAR(depth.data()[i] / 256.0, ref.depth.data()[i], 0.5 / 256 + 1e-6);
    ++valid;
  }
  EXPECT_GT(valid, depth.pixels() / 3);
}

TEST(Writers, TumFilesParseBackExactly) {
  test::TempDir dir;
  RoomOptions o;
  MeshScene scene(build_room(o), Environment::indoor());
  const auto traj = room_trajectory(o, 3);
  const Camera cam = tum_camera(64, 48);
  render_sequence(scene, traj, cam, SequenceOptions{}, dir.path());
  const auto rgb = lines(dir / "rgb.txt"), depth = lines(dir / "depth.txt");
  ASSERT_EQ(rgb.size(), 3u);
  ASSERT_EQ(depth.size(), 3u);
  EXPECT_EQ(rgb[1], "0.033333 rgb/0.033333.png");
  const Trajectory gt = read_tum_trajectory(dir / "groundtruth.txt");
  ASSERT_EQ(gt.size(), 3u);
  EXPECT_NEAR(gt.stamps[2], traj.stamps[2], 1e-6);
  EXPECT_LT((gt.poses[2].matrix() - traj.poses[2].matrix()).norm(), 1e-6);
  const auto cam_line = lines(dir / "camera.txt");
  ASSERT_EQ(cam_line.size(), 1u);
  EXPECT_EQ(cam_line[0].substr(0, 26), "52.5 52.5 31.5 23.5 64 48 ");

  RenderedFrame ref;
  Rasterizer r;
  render_frame(r, scene, cam, traj.poses[1], 0, RenderOptions{}, ref);
  const Image8 img = read_image8(dir / "rgb" / "0.033333.png");
  EXPECT_EQ(img.vec(), ref.left.vec());
  const Image16 d = read_png16(dir / "depth" / "0.033333.png");
  for (size_t i = 0; i < d.pixels(); ++i) ASSERT_NEAR(d.data()[i] / 5000.0, ref.depth.data()[i], 0.5 / 5000 + 1e-6);
}

TEST(Writers, RewritingAFolderDropsTheOldFrames) {
  test::TempDir dir;
  RoomOptions o;
  MeshScene scene(build_room(o), Environment::indoor());
  const Camera cam = tum_camera(32, 24);
  render_sequence(scene, room_trajectory(o, 4), cam, SequenceOptions{}, dir.path());
  o.start_time = 100;  // other names: the old files would survive a plain overwrite
  render_sequence(scene, room_trajectory(o, 2), cam, SequenceOptions{}, dir.path());
  size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir / "rgb")) n += e.path().extension() == ".png";
  EXPECT_EQ(n, 2u);
  EXPECT_EQ(lines(dir / "rgb.txt").size(), 2u);
}

TEST(Street, FarTextureMatchesASupersampledRender) {
  // Detail finer than a pixel is filtered out rather than point-sampled: inside surfaces (not at
  // their edges) beyond 25 m, a 1x render is close to a 4x4 supersampled one: measured 0.37 of the
  // image gradient; 3 mm white noise on the façades (aliasing) raises it to 0.48.
  StreetOptions o;
  o.length_m = 200;
  const auto traj = street_trajectory(o);
  StreetWorld world(o);
  const Camera cam = kitti_camera(310, 94);
  const int k = 4;
  const Camera big(cam.width * k, cam.height * k, cam.fx * k, cam.fy * k, (cam.cx + 0.5) * k - 0.5,
                   (cam.cy + 0.5) * k - 0.5);
  Rasterizer r;
  double diff = 0, contrast = 0;
  for (size_t fi : {20u, 120u}) {
    RenderedFrame a, b;
    render_frame(r, world, cam, traj.poses[fi], 0, RenderOptions{}, a);
    render_frame(r, world, big, traj.poses[fi], 0, RenderOptions{}, b);
    for (int y = 1; y < cam.height; ++y)
      for (int x = 1; x < cam.width; ++x) {
        float dmin = 1e9f, dmax = 0;
        double mean[3] = {0, 0, 0};
        for (int j = 0; j < k; ++j)
          for (int i = 0; i < k; ++i) {
            const float d = b.depth(x * k + i, y * k + j);
            dmin = std::min(dmin, d), dmax = std::max(dmax, d);
            for (int c = 0; c < 3; ++c) mean[c] += b.left(x * k + i, y * k + j, c) / double(k * k);
          }
        if (dmin < 25 || dmax > 1.02f * dmin) continue;  // near, sky or an edge between surfaces
        for (int c = 0; c < 3; ++c) {
          diff += std::abs(a.left(x, y, c) - mean[c]);
          contrast += std::abs(int(a.left(x, y, c)) - int(a.left(x - 1, y, c)));
        }
      }
  }
  ASSERT_GT(contrast, 0);
  std::printf("far texture: |1x - supersampled| / |gradient| = %.3f\n", diff / contrast);
  EXPECT_LT(diff / contrast, 0.42) << "difference " << diff << ", contrast " << contrast;
}

}  // namespace chungs::synth
