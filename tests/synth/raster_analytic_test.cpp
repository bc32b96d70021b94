// Rasterizer against float64 ray-plane intersection on random cameras, poses and planes, and
// crack-free coverage of shared-vertex meshes cut by the near plane.
#include <gtest/gtest.h>
#include <omp.h>

#include <cstring>
#include <fstream>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/synth/ply.hpp"
#include "chungs/synth/rasterizer.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/scene.hpp"
#include "test_support.hpp"

namespace chungs::synth {
namespace {

using V3 = Eigen::Vector3d;

// Depth along the optical axis where pixel (u, v)'s ray meets the plane n . X = c (world), or 0.
double plane_depth(const Camera& cam, const SE3& T_wc, const V3& n, double c, int u, int v) {
  const V3 ray_c((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
  const V3 rw = T_wc.rotation() * ray_c;
  const double den = n.dot(rw);
  if (std::abs(den) < 1e-12) return 0;
  const double z = (c - n.dot(T_wc.t)) / den;
  return z > 0 ? z : 0;
}

}  // namespace

TEST(MeshRasterizer, TiltedPlaneDepthMatchesRayIntersectionOnRandomPoses) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int trial = 0; trial < 6; ++trial) {
    const Camera cam(120 + trial * 7, 90 + trial * 3, 90 + 20 * U(rng), 95 + 20 * U(rng), 60 + 5 * U(rng), 45 + 5 * U(rng));
    Eigen::Matrix<double, 6, 1> xi;
    for (int k = 0; k < 6; ++k) xi[k] = 0.4 * U(rng);
    const SE3 T_wc = SE3::exp(xi);
    // A plane 2..6 m in front of the camera, tilted up to ~50 degrees, as one big quad.
    const V3 fwd = T_wc.rotation().col(2);
    const V3 n = (-fwd + 0.6 * V3(U(rng), U(rng), U(rng))).normalized();
    const V3 p0 = T_wc.t + (2 + 4 * (U(rng) + 1) / 2) * fwd;
    V3 a = n.cross(V3(0.3, 1, 0.2)).normalized(), b = n.cross(a);
    Mesh m;
    m.origin = p0;
    MeshBuilder mb(m);
    const uint16_t id = mb.add_material(Material{});
    auto P = [&](double s, double t) { return (s * a + t * b).cast<float>().eval(); };
    mb.quad(P(-60, -60), P(60, -60), P(60, 60), P(-60, 60), id);
    m.compute_bounds();
    Rasterizer r;
    ImageF rgb, d;
    RenderOptions opt;
    opt.far = 1e4;
    r.render({&m}, cam, T_wc, Environment::indoor(), opt, rgb, d);
    const double c = n.dot(p0);
    int checked = 0;
    for (int v = 0; v < cam.height; ++v)
      for (int u = 0; u < cam.width; ++u) {
        const double z = plane_depth(cam, T_wc, n, c, u, v);
        if (z <= 0) continue;
        const V3 hit = T_wc * V3((u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z);
        if (std::abs(a.dot(hit - p0)) > 59 || std::abs(b.dot(hit - p0)) > 59) continue;  // off the quad
        ASSERT_NEAR(d(u, v), z, 1e-4 * z) << "trial " << trial << " pixel " << u << "," << v;
        ++checked;
      }
    EXPECT_GT(checked, cam.width * cam.height / 3);
  }
}

TEST(MeshRasterizer, SharedEdgesLeaveNoCracksWhereTheNearPlaneCuts) {
  // An irregular triangulation (interior vertices jittered within the plane) of a floor 0.6 m
  // below the camera, from 3 m behind it to 60 m ahead, in cells so large that the first row's
  // triangles, cut by the near plane, fill the bottom of the image: every pixel whose ray lands on
  // the floor must be covered, with the plane's exact depth.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> J(-0.35f, 0.35f);
  const int N = 12;
  const float x0 = -30, x1 = 30, z0 = -3, z1 = 60;
  Mesh m;
  for (int j = 0; j <= N; ++j)
    for (int i = 0; i <= N; ++i) {
      float x = x0 + (x1 - x0) * i / N, z = z0 + (z1 - z0) * j / N;
      if (i > 0 && i < N && j > 0 && j < N) x += J(rng) * (x1 - x0) / N, z += J(rng) * (z1 - z0) / N;
      m.vertices.emplace_back(x, 0.6f, z);
    }
  auto idx = [&](int i, int j) { return uint32_t(j * (N + 1) + i); };
  for (int j = 0; j < N; ++j)
    for (int i = 0; i < N; ++i) {
      m.faces.push_back({idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)});
      m.faces.push_back({idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)});
    }
  m.materials.push_back(Material{});
  m.compute_bounds();
  const Camera cam(160, 120, 100, 100, 79.5, 59.5);
  Rasterizer r;
  ImageF rgb, d;
  r.render({&m}, cam, SE3(), Environment::indoor(), RenderOptions{}, rgb, d);
  int checked = 0;
  for (int v = 60; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const double z = 0.6 * cam.fy / (v - cam.cy), x = (u - cam.cx) / cam.fx * z;
      if (z > z1 - 0.5 || std::abs(x) > x1 - 0.5) continue;
      ASSERT_NEAR(d(u, v), z, 1e-4 * z) << u << "," << v;
      ++checked;
    }
  EXPECT_GT(checked, 3000);
}

TEST(MeshRasterizer, OutputDoesNotDependOnThreadCount) {
  RoomOptions o;
  o.seed = 3;
  MeshScene scene(build_room(o), Environment::indoor());
  const Camera cam = tum_camera(200, 150);
  const SE3 pose = room_trajectory(o, 40).poses[39];
  const int threads = omp_get_max_threads();
  ImageF rgb1, d1, rgb2, d2;
  Rasterizer r;
  omp_set_num_threads(1);
  r.render(scene.gather(cam, pose, 50), cam, pose, scene.environment(), RenderOptions{}, rgb1, d1);
  omp_set_num_threads(3);
  r.render(scene.gather(cam, pose, 50), cam, pose, scene.environment(), RenderOptions{}, rgb2, d2);
  omp_set_num_threads(threads);
  EXPECT_EQ(rgb1.vec(), rgb2.vec());
  EXPECT_EQ(d1.vec(), d2.vec());
}

TEST(Ply, ReadsBinaryLittleEndianWithExtraPropertiesAndRejectsBigEndian) {
  test::TempDir dir;
  {
    std::ofstream f(dir / "b.ply", std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\ncomment hand-made\nelement vertex 3\nproperty float x\n"
         "property float y\nproperty float z\nproperty float nx\nproperty uchar red\nproperty uchar green\n"
         "property uchar blue\nproperty uchar alpha\nelement face 1\nproperty list uchar int vertex_indices\n"
         "property int flags\nend_header\n";
    auto put = [&](const void* p, size_t n) { f.write(static_cast<const char*>(p), std::streamsize(n)); };
    for (int v = 0; v < 3; ++v) {
      const float xyz[4] = {float(v), 2.5f * v, -1.f, 0.f};
      const uint8_t rgba[4] = {uint8_t(10 * v), 20, 30, 255};
      put(xyz, 16);
      put(rgba, 4);
    }
    const uint8_t n = 3;
    const int32_t ids[3] = {2, 0, 1}, flags = 77;
    put(&n, 1);
    put(ids, 12);
    put(&flags, 4);
  }
  const Mesh m = read_ply(dir / "b.ply");
  ASSERT_EQ(m.vertices.size(), 3u);
  ASSERT_EQ(m.triangles(), 1u);
  EXPECT_FLOAT_EQ(m.vertices[2].y(), 5.f);
  EXPECT_EQ(m.faces[0][0], 2u);
  EXPECT_EQ(m.colors[1][0], 10);
  EXPECT_EQ(m.materials[0].kind, MaterialKind::VertexColor);

  std::ofstream(dir / "be.ply") << "ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n";
  try {
    read_ply(dir / "be.ply");
    FAIL() << "big-endian PLY accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("be.ply"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "idx.ply") << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                    "end_header\n0 0 0\n3 0 1 2\n";
  EXPECT_THROW(read_ply(dir / "idx.ply"), Error);
}

}  // namespace chungs::synth
