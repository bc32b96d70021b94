// A ray-cast synthetic room for tracker tests: the box [-3,3] x [-1.5,1.5] x [-3,3] (y down) with blocky
// textured walls, rendered with exact depth. Cheap enough to render hundreds of small frames in a test.
#pragma once
#include <cmath>
#include <cstdint>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/image/image.hpp"

namespace chungs::test {

inline uint32_t hash2(int a, int b, uint32_t seed) {
  uint32_t h = uint32_t(a) * 73856093u ^ uint32_t(b) * 19349663u ^ seed * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  return h ^ (h >> 15);
}

// Intensity of a wall at wall coordinates (a, b): coarse blocks with finer blocks on top.
inline uint8_t texture(double a, double b, int wall) {
  int coarse = int(hash2(int(std::floor(a * 4)), int(std::floor(b * 4)), uint32_t(wall)) % 160);
  int fine = int(hash2(int(std::floor(a * 12)), int(std::floor(b * 12)), uint32_t(wall + 7)) % 90);
  return uint8_t(coarse + fine);
}

// Renders the room [-3,3] x [-1.5,1.5] x [-3,3] (y down) from camera-to-world pose T_wc.
inline void render_room(const Camera& cam, const SE3& T_wc, Image8& img, ImageF& depth) {
  img = Image8(cam.width, cam.height, 1);
  depth = ImageF(cam.width, cam.height, 1);
  const Eigen::Vector3d lo(-3, -1.5, -3), hi(3, 1.5, 3);
  const Eigen::Matrix3d R = T_wc.rotation();
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Eigen::Vector3d dc((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0);  // z = 1: t is the depth
      Eigen::Vector3d d = R * dc, o = T_wc.t;
      double best = 1e9;
      int wall = -1;
      for (int ax = 0; ax < 3; ++ax) {
        if (std::abs(d[ax]) < 1e-12) continue;
        double t = ((d[ax] > 0 ? hi[ax] : lo[ax]) - o[ax]) / d[ax];
        if (t > 0 && t < best) best = t, wall = ax * 2 + (d[ax] > 0);
      }
      Eigen::Vector3d p = o + best * d;
      const int ax = wall / 2;
      double a = p[(ax + 1) % 3], b = p[(ax + 2) % 3];
      img(x, y) = texture(a, b, wall);
      depth(x, y) = float(best);
    }
}


}  // namespace chungs::test
