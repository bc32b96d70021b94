// Procedural materials: colour as a function of the world-space surface point, its normal and the
// pixel footprint (for anti-aliasing), plus the environment (light, sky, haze). World z is up.
#pragma once
#include <Eigen/Core>

#include "chungs/synth/mesh.hpp"

namespace chungs::synth {

struct SurfacePoint {
  Eigen::Vector3d p;          // world position
  Eigen::Vector3f n;          // unit face normal, facing the viewer
  double s = 0, t = 0;        // planar texture coordinates in metres: (x, y) on horizontal faces,
                              // (horizontal, height) on vertical ones
  double fs = 1e-3, ft = 1e-3;  // pixel footprint along s and t, metres
  bool vertical = false;
  Eigen::Vector3f vertex_color{0, 0, 0};  // interpolated, for VertexColor
};

// Unlit surface colour in [0, 1] (approximately; the renderer clamps).
Eigen::Vector3f shade_material(const Material& m, const SurfacePoint& sp);

struct Environment {
  bool sky = false;                             // sky dome for rays that hit nothing, else background
  Eigen::Vector3f background{0.f, 0.f, 0.f};
  Eigen::Vector3d light_dir{0.35, 0.25, 0.90};  // unit, towards the light
  float ambient = 0.55f, diffuse = 0.45f;       // lit colour = albedo * (ambient + diffuse * max(0, n.l))
  float fog_start = 0, fog_end = 0;             // metres; haze towards the sky colour, off when end <= start
  uint32_t seed = 0;                            // clouds

  static Environment indoor();
  static Environment outdoor(uint32_t seed, double far);
};

// Colour seen along a world direction that hits nothing (sky gradient and clouds at infinity, so
// they move only with rotation, as a real sky does).
Eigen::Vector3f background_color(const Environment& env, const Eigen::Vector3d& dir);

// Per-kind implementations (materials_indoor.cpp, materials_outdoor.cpp).
namespace detail {
Eigen::Vector3f flat(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f plaster(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f wallpaper(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f brick(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f wood(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f fabric(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f tiles(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f poster(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f books(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f paint(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f facade(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f asphalt(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f paving(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f concrete(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f grass(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f foliage(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f bark(const Material& m, const SurfacePoint& sp);
Eigen::Vector3f glass(const Material& m, const SurfacePoint& sp);
}  // namespace detail

}  // namespace chungs::synth
