// The generator's pieces against analytic cases, and its outputs read back by the dataset readers.
#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/synth/ply.hpp"
#include "chungs/synth/rasterizer.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/sequence.hpp"
#include "chungs/synth/street.hpp"
#include "test_support.hpp"

namespace chungs::synth {
namespace {

// A square of half-size h at z = depth in front of the identity camera, facing it.
Mesh plane_mesh(double depth, float h) {
  Mesh m;
  MeshBuilder b(m);
  Material mat;
  uint16_t id = b.add_material(mat);
  b.quad({-h, -h, float(depth)}, {h, -h, float(depth)}, {h, h, float(depth)}, {-h, h, float(depth)}, id);
  m.compute_bounds();
  return m;
}

double mean_abs_gradient(const Image8& img) {
  double s = 0;
  size_t n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 1; x < img.width(); ++x, ++n) s += std::abs(int(img(x, y, 0)) - int(img(x - 1, y, 0)));
  return s / double(n);
}

}  // namespace

TEST(Ply, ReadsAsciiMeshWithColours) {
  test::TempDir dir;
  std::ofstream(dir / "t.ply") << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                  "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                                  "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                  "0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 9 9 9\n4 0 1 2 3\n";
  Mesh m = read_ply(dir / "t.ply");
  EXPECT_EQ(m.vertices.size(), 4u);
  EXPECT_EQ(m.triangles(), 2u);  // the quad is fan-triangulated
  ASSERT_EQ(m.colors.size(), 4u);
  EXPECT_EQ(m.colors[2][2], 255);
  std::ofstream(dir / "bad.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n0\n";
  try {
    read_ply(dir / "bad.ply");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.ply"), std::string::npos) << e.what();
  }
}

TEST(Ply, ReadsTheReplicaMesh) {
  CHUNGS_REQUIRE_DATA("replica_office0");
  Mesh m = read_ply(test::shared_data("replica_office0/office0_mesh.ply"));
  EXPECT_EQ(m.vertices.size(), 25149u);
  EXPECT_EQ(m.triangles(), 50000u);
  EXPECT_EQ(m.colors.size(), 25149u);
}

TEST(MeshRasterizer, PlaneAtKnownDepthIsExactEverywhere) {
  for (double depth : {0.7, 3.0, 42.0}) {
    Mesh m = plane_mesh(depth, float(depth * 10));
    Camera cam(97, 61, 80, 83, 47.3, 29.6);
    Rasterizer r;
    ImageF rgb, d;
    r.render({&m}, cam, SE3(), Environment::indoor(), RenderOptions{}, rgb, d);
    for (float v : d.vec()) ASSERT_NEAR(v, depth, 1e-4 * depth);
  }
}

TEST(MeshRasterizer, CoverageMatchesProjectionAndNearClippingKeepsVisiblePart) {
  // A square of side 2 at z = 4: covers pixels whose rays hit |x|,|y| < 1, i.e. |u - cx| < f/4.
  Mesh m = plane_mesh(4.0, 1.0f);
  Camera cam(200, 160, 100, 100, 99.5, 79.5);
  Rasterizer r;
  ImageF rgb, d;
  r.render({&m}, cam, SE3(), Environment::indoor(), RenderOptions{}, rgb, d);
  int covered = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      bool inside = std::abs(x - cam.cx) < 25 && std::abs(y - cam.cy) < 25;
      bool edge = std::abs(std::abs(x - cam.cx) - 25) < 0.6 || std::abs(std::abs(y - cam.cy) - 25) < 0.6;
      if (!edge) {
        EXPECT_EQ(d(x, y) > 0, inside) << x << "," << y;
      }
      covered += d(x, y) > 0;
    }
  EXPECT_NEAR(covered, 50 * 50, 60);
  // A floor running from behind the camera to far ahead crosses the near plane: its visible part
  // must still be drawn (the lower image half), with depth growing towards the horizon.
  Mesh floor;
  MeshBuilder b(floor);
  uint16_t id = b.add_material(Material{});
  b.quad({-50, 1.5f, -20}, {50, 1.5f, -20}, {50, 1.5f, 80}, {-50, 1.5f, 80}, id);
  floor.compute_bounds();
  r.render({&floor}, cam, SE3(), Environment::indoor(), RenderOptions{}, rgb, d);
  EXPECT_GT(d(100, 159), 0.f);
  EXPECT_NEAR(d(100, 159), 1.5 * 100 / (159 - 79.5), 1e-3);
  EXPECT_EQ(d(100, 40), 0.f);  // above the horizon: sky
}

TEST(Room, SameSeedSameBytesAndTexturedImages) {
  RoomOptions o;
  o.seed = 7;
  Camera cam = tum_camera(160, 120);
  auto traj = room_trajectory(o, 3);
  RenderedFrame a, b;
  Rasterizer r1, r2;
  MeshScene s1(build_room(o), Environment::indoor()), s2(build_room(o), Environment::indoor());
  render_frame(r1, s1, cam, traj.poses[2], 0, RenderOptions{}, a);
  render_frame(r2, s2, cam, traj.poses[2], 0, RenderOptions{}, b);
  EXPECT_EQ(a.left.vec(), b.left.vec());
  EXPECT_GT(mean_abs_gradient(a.left), 2.0);
  size_t valid = 0;
  for (float v : a.depth.vec()) valid += v > 0;
  EXPECT_EQ(valid, a.depth.pixels());  // a closed room: every pixel hits something
}

TEST(Writers, TumAndKittiOutputsLoadThroughTheReaders) {
  test::TempDir dir;
  RoomOptions o;
  MeshScene scene(build_room(o), Environment::indoor());
  Camera cam(320, 240, 301, 305, 158.25, 121.5);  // not the TUM default: calib.txt must carry it
  auto traj = room_trajectory(o, 4);
  SequenceOptions so;
  render_sequence(scene, traj, cam, so, dir / "tum");
  auto ds = open_dataset("tum:" + (dir / "tum").string());
  ASSERT_EQ(ds->size(), 4u);
  EXPECT_DOUBLE_EQ(ds->info().camera.fy, 305);
  EXPECT_DOUBLE_EQ(ds->info().camera.cx, 158.25);
  Frame f = ds->frame(3);
  ASSERT_TRUE(f.depth && f.gt_pose);
  EXPECT_LT((f.gt_pose->matrix() - traj.poses[3].matrix()).norm(), 1e-5);
  RenderedFrame ref;
  Rasterizer r;
  render_frame(r, scene, cam, traj.poses[3], 0, RenderOptions{}, ref);
  EXPECT_NEAR((*f.depth)(160, 120), ref.depth(160, 120), 1.0 / 5000);

  so.layout = Layout::Kitti;
  so.baseline = 0.2;
  render_sequence(scene, traj, cam.scaled(0.5), so, dir / "kitti");
  auto k = open_dataset("kitti:" + (dir / "kitti").string());
  ASSERT_EQ(k->size(), 4u);
  EXPECT_NEAR(k->info().baseline, 0.2, 1e-6);
  EXPECT_TRUE(k->frame(1).right.has_value());
}

TEST(Street, RouteRevisitsStreetsAndWorldStaysBounded) {
  StreetOptions o;
  o.length_m = 1500;
  auto traj = street_trajectory(o);
  ASSERT_GT(traj.size(), 1400u);
  // A loop: some position is revisited (within 5 m) after the route went more than 50 m away.
  bool revisit = false;
  for (size_t i = 0; i < traj.size() && !revisit; i += 5) {
    bool left = false;
    for (size_t j = i + 1; j < traj.size(); ++j) {
      double d = (traj.poses[j].t - traj.poses[i].t).norm();
      if (d > 50) left = true;
      if (left && d < 5) {
        revisit = true;
        break;
      }
    }
  }
  EXPECT_TRUE(revisit);
  for (size_t i = 1; i < traj.size(); ++i) ASSERT_NEAR((traj.poses[i].t - traj.poses[i - 1].t).norm(), 1.0, 0.05);
  StreetWorld world(o);
  Camera cam = kitti_camera(310, 94);
  RenderedFrame f;
  Rasterizer r;
  for (size_t i = 0; i < traj.size(); i += 100) render_frame(r, world, cam, traj.poses[i], 0.54, RenderOptions{}, f);
  EXPECT_GT(mean_abs_gradient(f.left), 2.0);
  EXPECT_LE(world.blocks_in_memory(), o.max_blocks);
}

}  // namespace chungs::synth
