// Materials of the street world: façades with windows, roads with markings, sidewalks, vegetation.
#include <algorithm>
#include <cmath>

#include "chungs/synth/materials.hpp"
#include "chungs/synth/noise.hpp"

namespace chungs::synth::detail {
namespace {

using C3 = Eigen::Vector3f;

C3 mix(const C3& a, const C3& b, float t) { return a + t * (b - a); }
double fpn(const SurfacePoint& sp) { return std::max(sp.fs, sp.ft); }

// Road markings of the street grid (pitch G, road width W, roads centred on multiples of G) for a
// road running along `x` with lateral offset dy from its centreline; dxi is the offset from the
// nearest intersection centre along the road. fx, fy are the footprints along x and y.
float road_marks(double x, double dy, double dxi, double W, double fx, double fy) {
  const double hw = 0.5 * W;
  if (std::abs(dy) > hw) return 0;
  const float away = 1 - box_coverage(dxi, -hw, hw, fx);  // outside the intersection square
  const float far_from_cross = 1 - box_coverage(dxi, -(hw + 4), hw + 4, fx);
  const float centre = box_coverage(dy, -0.07, 0.07, fy) * pulse_train(x, 6.0, 0, 3.0, fx) * far_from_cross;
  const float edge = box_coverage(std::abs(dy), hw - 0.35, hw - 0.2, fy) * away;
  const float zebra = pulse_train(dy + 0.25, 1.0, 0, 0.5, fy) * box_coverage(dy, 0.6 - hw, hw - 0.6, fy) *
                      box_coverage(std::abs(dxi), hw + 0.6, hw + 3.4, fx);
  const float stop = box_coverage(std::abs(dxi), hw + 3.8, hw + 4.2, fx) *
                     box_coverage(dy * (dxi > 0 ? 1 : -1), -(hw - 0.4), 0, fy);
  return std::max({centre, edge, zebra, stop});
}

}  // namespace

C3 facade(const Material& m, const SurfacePoint& sp) {
  const double H = m.scale, P = std::max(1.0f, m.param), fp = fpn(sp);
  const double su = sp.s + hash01(m.seed, 1, 7) * P;
  C3 wall;
  if (m.seed & 1) {
    Material b = m;
    b.kind = MaterialKind::Brick;
    b.scale = 0.075f;
    b.b = C3(0.78f, 0.76f, 0.72f);
    wall = brick(b, sp);
  } else {
    wall = plaster(m, sp);
  }
  // Dark plinth and a cornice line at every storey.
  wall = mix(wall, wall * 0.6f, box_coverage(sp.t, -1.0, 0.5, sp.ft));
  wall = mix(wall, m.b * 0.3f + wall * 0.5f, line_train(sp.t, H, 0.16, sp.ft));
  if (sp.t < 0.05) return wall;

  const bool ground = sp.t < H;
  const double ua = ground ? 0.1 * P : 0.28 * P, ub = ground ? 0.9 * P : 0.72 * P;
  const double va = ground ? 0.35 : 0.9, vb = ground ? H - 0.35 : H - 0.55;
  auto cover_t = [&](double a, double b) {
    return ground ? box_coverage(sp.t, a, b, sp.ft) : pulse_train(sp.t, H, a, b, sp.ft);
  };
  const double fm = 0.08;
  const float frame = pulse_train(su, P, ua - fm, ub + fm, sp.fs) * cover_t(va - fm, vb + fm);
  if (frame <= 0) return wall;
  const float glass_cov = pulse_train(su, P, ua, ub, sp.fs) * cover_t(va, vb);
  const float sill = ground ? 0.f : pulse_train(su, P, ua - 0.15, ub + 0.15, sp.fs) * cover_t(va - 0.2, va - fm);

  const int64_t wi = int64_t(std::floor(su / P)), fi = int64_t(std::floor(sp.t / H));
  const float h = hash01(wi, fi, m.seed + 11);
  const double lv = sp.t - fi * H;  // height within the storey
  // Glass: reflections of sky and opposite buildings as smeared noise; some windows are lit,
  // some have curtains.
  const float refl = fbm(su * 0.3 + 0.2 * sp.t, sp.t * 1.5, 0.6, 4, m.seed + 12, fp * 1.5);
  C3 glass = mix(C3(0.10f, 0.13f, 0.18f), C3(0.55f, 0.62f, 0.7f), clamp01(0.35f + 0.6f * refl));
  if (h < 0.12f) {
    glass = C3(0.85f, 0.72f, 0.45f) * (0.85f + 0.15f * refl);
  } else if (h < 0.45f) {
    const C3 curtain = C3(0.75f, 0.70f, 0.60f) * (0.7f + 0.5f * hash01(wi, fi, m.seed + 13));
    const float folds = 0.85f + 0.15f * pulse_train(su, 0.14, 0, 0.07, sp.fs);
    const double drop = va + (vb - va) * (0.3 + 0.6 * hash01(wi, fi, m.seed + 14));
    const float cov = ground ? 0.f : 1 - smoothstep(float(drop - 0.02), float(drop + 0.02), float(lv));
    glass = mix(glass, curtain * folds, cov);
  }
  const C3 frame_col = (m.seed & 2) ? C3(0.88f, 0.87f, 0.84f) : C3(0.22f, 0.2f, 0.18f);
  // Mullion and transom split each window into panes.
  const double mid_u = 0.5 * (ua + ub), tr_v = va + 0.68 * (vb - va);
  const float mull = pulse_train(su, P, mid_u - 0.03, mid_u + 0.03, sp.fs) * cover_t(va, vb);
  const float transom = pulse_train(su, P, ua, ub, sp.fs) * cover_t(tr_v - 0.03, tr_v + 0.03);
  C3 c = mix(wall, frame_col, frame);
  c = mix(c, glass, glass_cov);
  c = mix(c, frame_col, std::max(mull, transom));
  return mix(c, C3(0.75f, 0.74f, 0.7f), sill);
}

C3 asphalt(const Material& m, const SurfacePoint& sp) {
  const double fp = fpn(sp), x = sp.p.x(), y = sp.p.y();
  // Aggregate from 25 cm down to 1.5 cm, filtered anisotropically: the road is seen at grazing
  // angles, where the footprint along the view is many times the one across it.
  const float agg = fbm_aniso(x, y, 0.25, 5, m.seed, sp.fs, sp.ft, 0.8f);
  const float mid = fbm(x, y, 2.5, 4, m.seed + 1, fp, 0.6f);
  const float patch = smoothstep(0.2f, 0.3f, fbm(x, y, 9.0, 2, m.seed + 2, fp));
  C3 c = m.a * (1 + 0.6f * agg + 0.3f * mid) * (1 - 0.25f * patch);
  const double G = m.param, W = m.scale;
  if (G > 0 && W > 0) {
    const double dy = y - std::round(y / G) * G, dxi = x - std::round(x / G) * G;
    // Footprints along world x and y: s = x, t = y on horizontal faces.
    const float mark = std::max(road_marks(x, dy, dxi, W, sp.fs, sp.ft), road_marks(y, dxi, dy, W, sp.ft, sp.fs));
    if (mark > 0) {
      const float wear = 0.8f + 0.2f * fbm(x, y, 0.4, 4, m.seed + 3, fp);
      c = mix(c, C3(0.86f, 0.86f, 0.82f) * wear, mark);
    }
  }
  return c;
}

C3 paving(const Material& m, const SurfacePoint& sp) {
  const double T = m.scale, fp = fpn(sp);
  const float joints = std::max(line_train(sp.s, T, 0.012, sp.fs), line_train(sp.t, T, 0.012, sp.ft));
  const float h = hash01(int64_t(std::floor(sp.s / T)), int64_t(std::floor(sp.t / T)), m.seed);
  const float tint = 1 + 0.2f * (h - 0.5f) * detail_weight(T, fp);
  const float grain = fbm_aniso(sp.s, sp.t, 0.1, 4, m.seed + 1, sp.fs, sp.ft, 0.7f);
  const float stain = smoothstep(0.1f, 0.5f, fbm(sp.s, sp.t, 3.0, 3, m.seed + 2, fp));
  return mix(m.a * (tint + 0.2f * grain) * (1 - 0.2f * stain), m.b, joints);
}

C3 concrete(const Material& m, const SurfacePoint& sp) {
  const double fp = fpn(sp);
  const float n = fbm(sp.s, sp.t, 1.2, 8, m.seed, fp);
  const float holes = smoothstep(0.45f, 0.65f, fbm(sp.s, sp.t, 0.04, 2, m.seed + 1, fp));
  const float panels = std::max(line_train(sp.s, m.scale, 0.012, sp.fs), line_train(sp.t, m.scale, 0.012, sp.ft));
  return m.a * (1 + 0.15f * n) * (1 - 0.35f * holes) * (1 - 0.4f * panels);
}

C3 grass(const Material& m, const SurfacePoint& sp) {
  const double fp = fpn(sp);
  const float n = fbm_aniso(sp.s, sp.t, 2.5, 9, m.seed, sp.fs, sp.ft, 0.6f);
  const float dry = smoothstep(0.2f, 0.6f, fbm(sp.s, sp.t, 6.0, 2, m.seed + 1, fp));
  C3 c = mix(m.a, m.b, clamp01(0.5f + 1.2f * n));
  return mix(c, C3(0.55f, 0.5f, 0.3f), 0.4f * dry);
}

C3 foliage(const Material& m, const SurfacePoint& sp) {
  const double fp = fpn(sp);
  // Noise on s, t plus the third coordinate so that crowns (faces of all orientations) vary.
  const double w = sp.vertical ? sp.p.x() + sp.p.y() : sp.p.z();
  const float n = fbm(sp.s + 0.37 * w, sp.t - 0.21 * w, m.scale, 7, m.seed, fp, 0.6f);
  const float holes = smoothstep(-0.55f, -0.2f, fbm(sp.s, sp.t + w, 0.5 * m.scale, 4, m.seed + 1, fp));
  return mix(m.a, m.b, smoothstep(-0.35f, 0.45f, n)) * (0.45f + 0.55f * holes);
}

C3 bark(const Material& m, const SurfacePoint& sp) {
  // Streaks: noise stretched 10x along the trunk.
  const float n = fbm(sp.s * 6.0, sp.t * 0.6, 0.4, 5, m.seed, std::max(sp.fs * 6.0, sp.ft * 0.6));
  return mix(m.a, m.b, clamp01(0.5f + 0.8f * n));
}

C3 glass(const Material& m, const SurfacePoint& sp) {
  const float refl = fbm(sp.s * 0.5 + 0.3 * sp.t, sp.t, 0.8, 4, m.seed, fpn(sp) * 1.5);
  return mix(m.a, m.b, clamp01(0.3f + 0.7f * refl));
}

}  // namespace chungs::synth::detail
