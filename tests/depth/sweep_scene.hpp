// A small ray-cast scene for the plane sweep's tests: textured rectangles (value noise fixed to the
// surface, so every view sees the same texture) with exact depth, seen by pinhole cameras.
#pragma once
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/image/image.hpp"

namespace chungs::test {

struct Quad {
  Eigen::Vector3d origin, u, v;  // the points origin + a u + b v, a and b in [0, 1]; u orthogonal to v
  double cell = 0.15;            // texture lattice spacing, metres
  uint32_t seed = 1;
  bool flat = false;             // one gray level: no texture at all
  double gain = 1, offset = 0;   // the texture's gray levels scaled and shifted
  double level = 128;            // the gray level of a flat quad
};

inline double lattice(uint32_t seed, int64_t i, int64_t j) {
  uint64_t h = uint64_t(i) * 0x9E3779B97F4A7C15ull ^ uint64_t(j) * 0xC2B2AE3D27D4EB4Full ^ uint64_t(seed) * 0x165667B19E3779F9ull;
  h ^= h >> 29, h *= 0xBF58476D1CE4E5B9ull, h ^= h >> 32;
  return double(h % 1000) / 999.0;
}

inline double value_noise(uint32_t seed, double s, double t) {
  const double fs = std::floor(s), ft = std::floor(t), a = s - fs, b = t - ft;
  const int64_t i = int64_t(fs), j = int64_t(ft);
  return (1 - b) * ((1 - a) * lattice(seed, i, j) + a * lattice(seed, i + 1, j)) +
         b * ((1 - a) * lattice(seed, i, j + 1) + a * lattice(seed, i + 1, j + 1));
}

struct SweepScene {
  std::vector<Quad> quads;
  Camera camera{160, 120, 120.0, 120.0, 79.5, 59.5};

  // Gray image (with Gaussian noise of `noise` gray levels) and exact depth (0 where no quad is hit).
  void render(const SE3& T_wc, Image8& gray, ImageF& depth, double noise, unsigned seed) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> N(0.0, noise);
    gray = Image8(camera.width, camera.height, 1, 0);
    depth = ImageF(camera.width, camera.height, 1, 0.0f);
    const Eigen::Matrix3d R = T_wc.rotation();
    for (int y = 0; y < camera.height; ++y)
      for (int x = 0; x < camera.width; ++x) {
        const Eigen::Vector3d dc((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0), d = R * dc;
        double best = 1e30, value = 0;
        for (const Quad& q : quads) {
          const Eigen::Vector3d n = q.u.cross(q.v);
          const double den = n.dot(d);
          if (std::abs(den) < 1e-12) continue;
          const double t = n.dot(q.origin - T_wc.t) / den;
          if (t <= 0 || t >= best) continue;
          const Eigen::Vector3d rel = T_wc.t + t * d - q.origin;
          const double a = rel.dot(q.u) / q.u.squaredNorm(), b = rel.dot(q.v) / q.v.squaredNorm();
          if (a < 0 || a > 1 || b < 0 || b > 1) continue;
          best = t;
          const double s = a * q.u.norm() / q.cell, tt = b * q.v.norm() / q.cell;
          value = q.flat ? q.level
                         : q.offset + q.gain * (40 + 130 * value_noise(q.seed, s, tt) +
                                                60 * value_noise(q.seed + 7, 2.3 * s, 2.3 * tt));
        }
        if (best < 1e30) depth(x, y) = float(best);  // t along a ray with camera z = 1 is the depth
        gray(x, y) = uint8_t(std::clamp(std::lround(value + (noise > 0 ? N(rng) : 0.0)), 0l, 255l));
      }
  }
};

// A wall at 6 m, a box face at 3.5 m in front of its middle (a depth step), and a flat gray patch on
// the wall (no texture).
inline SweepScene wall_box_scene() {
  SweepScene s;
  s.quads.push_back({{-8, -6, 6}, {16, 0, 0}, {0, 12, 0}, 0.15, 3, false});
  s.quads.push_back({{-1.2, -0.8, 3.5}, {1.6, 0, 0}, {0, 1.4, 0}, 0.09, 5, false});
  s.quads.push_back({{1.4, -2.0, 5.99}, {1.6, 0, 0}, {0, 1.6, 0}, 0.15, 9, true});
  return s;
}

inline SE3 translated(double x, double y, double z) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, y, z)); }

// The wall-and-box scene from the origin (with its exact depth) and from three neighbours: sideways,
// upwards and forwards (the last puts the epipole inside the image). input<T>() fills the camera,
// reference and neighbours that the plane sweep's and the multiview depth's inputs share.
struct SweepViews {
  SweepScene scene;
  Image8 ref;
  ImageF gt;
  std::vector<Image8> images;
  std::vector<SE3> poses;
  explicit SweepViews(SweepScene s = wall_box_scene()) : scene(std::move(s)) {
    ImageF unused;
    scene.render(SE3(), ref, gt, 1.5, 1);
    poses = {translated(0.35, 0, 0), translated(-0.2, 0.25, 0.1), translated(0.05, -0.05, 0.6)};
    images.resize(poses.size());
    for (size_t i = 0; i < poses.size(); ++i) scene.render(poses[i], images[i], unused, 1.5, unsigned(2 + i));
  }
  template <typename Input>
  Input input() const {
    Input in;
    in.camera = scene.camera;
    in.reference = {&ref, SE3()};
    for (size_t i = 0; i < images.size(); ++i) in.neighbours.push_back({&images[i], poses[i]});
    return in;
  }
};

}  // namespace chungs::test
