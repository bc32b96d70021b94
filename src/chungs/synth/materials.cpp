#include "chungs/synth/materials.hpp"

#include <cmath>

#include "chungs/synth/noise.hpp"

namespace chungs::synth {

Eigen::Vector3f shade_material(const Material& m, const SurfacePoint& sp) {
  switch (m.kind) {
    case MaterialKind::VertexColor: return sp.vertex_color;
    case MaterialKind::Flat: return detail::flat(m, sp);
    case MaterialKind::Plaster: return detail::plaster(m, sp);
    case MaterialKind::Wallpaper: return detail::wallpaper(m, sp);
    case MaterialKind::Brick: return detail::brick(m, sp);
    case MaterialKind::Facade: return detail::facade(m, sp);
    case MaterialKind::Wood: return detail::wood(m, sp);
    case MaterialKind::Fabric: return detail::fabric(m, sp);
    case MaterialKind::Tiles: return detail::tiles(m, sp);
    case MaterialKind::Asphalt: return detail::asphalt(m, sp);
    case MaterialKind::Paving: return detail::paving(m, sp);
    case MaterialKind::Concrete: return detail::concrete(m, sp);
    case MaterialKind::Grass: return detail::grass(m, sp);
    case MaterialKind::Foliage: return detail::foliage(m, sp);
    case MaterialKind::Bark: return detail::bark(m, sp);
    case MaterialKind::Paint: return detail::paint(m, sp);
    case MaterialKind::Glass: return detail::glass(m, sp);
    case MaterialKind::Poster: return detail::poster(m, sp);
    case MaterialKind::Books: return detail::books(m, sp);
  }
  return m.a;
}

Environment Environment::indoor() {
  Environment e;
  e.sky = false;
  e.background = {0.f, 0.f, 0.f};
  e.light_dir = Eigen::Vector3d(0.3, -0.45, 0.84).normalized();
  e.ambient = 0.6f;
  e.diffuse = 0.4f;
  return e;
}

Environment Environment::outdoor(uint32_t seed, double far) {
  Environment e;
  e.sky = true;
  e.light_dir = Eigen::Vector3d(0.45, 0.3, 0.84).normalized();
  e.ambient = 0.5f;
  e.diffuse = 0.55f;
  // Haze that reaches the sky colour exactly at the far plane, so culled geometry does not pop.
  e.fog_start = float(0.55 * far);
  e.fog_end = float(far);
  e.seed = seed;
  return e;
}

Eigen::Vector3f background_color(const Environment& env, const Eigen::Vector3d& dir) {
  if (!env.sky) return env.background;
  const Eigen::Vector3f horizon(0.80f, 0.85f, 0.90f), zenith(0.35f, 0.55f, 0.85f), ground(0.45f, 0.45f, 0.43f);
  const float up = float(dir.z());
  if (up <= 0) return horizon + std::min(1.f, -up * 4) * (ground - horizon);
  Eigen::Vector3f c = horizon + std::sqrt(up) * (zenith - horizon);
  // Clouds on a plane at unit height above the camera: (x, y) / z, low frequency only.
  const double inv = 1.0 / std::max(double(up), 0.05);
  // About 1/700 rad per pixel, stretched by 1/up^2 on the cloud plane towards the horizon.
  const double fp = 0.0015 * inv * inv;
  const float cl = fbm(dir.x() * inv, dir.y() * inv, 1.5, 4, env.seed ^ 0x5eedu, fp);
  const float cover = smoothstep(-0.05f, 0.45f, cl) * smoothstep(0.0f, 0.15f, up);
  return c + cover * (Eigen::Vector3f(0.95f, 0.95f, 0.96f) - c);
}

}  // namespace chungs::synth
