// Materials of rooms and furniture. Each draws detail from metres down to millimetres and fades
// out what the pixel footprint cannot resolve (noise.hpp).
#include <algorithm>
#include <cmath>

#include "chungs/synth/materials.hpp"
#include "chungs/synth/noise.hpp"

namespace chungs::synth::detail {
namespace {

using C3 = Eigen::Vector3f;

C3 mix(const C3& a, const C3& b, float t) { return a + t * (b - a); }
double fpn(const SurfacePoint& sp) { return std::max(sp.fs, sp.ft); }

// A saturated colour from a small palette, picked by hash value h in [0, 1).
C3 palette(float h, float shade) {
  static const C3 colors[] = {{0.80f, 0.15f, 0.12f}, {0.93f, 0.78f, 0.15f}, {0.12f, 0.25f, 0.65f},
                              {0.92f, 0.90f, 0.86f}, {0.10f, 0.10f, 0.12f}, {0.15f, 0.55f, 0.30f},
                              {0.85f, 0.45f, 0.15f}, {0.55f, 0.20f, 0.55f}, {0.35f, 0.65f, 0.80f}};
  int i = std::min(8, int(h * 9));
  return colors[i] * (0.75f + 0.4f * shade);
}

}  // namespace

C3 flat(const Material& m, const SurfacePoint& sp) {
  const double fp = fpn(sp);
  return m.a * (1 + 0.18f * fbm(sp.s, sp.t, 0.8, 7, m.seed, fp));
}

C3 plaster(const Material& m, const SurfacePoint& sp) {
  const double fp = fpn(sp);
  const float blotch = smoothstep(-0.25f, 0.5f, fbm(sp.s, sp.t, 2.0, 3, m.seed + 7, fp));
  // Trowel marks: a rougher fractal (gain 0.7) keeps contrast down to millimetres.
  const float grain = fbm(sp.s, sp.t, 0.4, 8, m.seed + 3, fp, 0.7f);
  return mix(m.a, m.b, 0.45f * blotch) * (1 + 0.28f * grain);
}

C3 wallpaper(const Material& m, const SurfacePoint& sp) {
  const double P = m.scale;
  const float band = pulse_train(sp.s, P, 0, 0.5 * P, sp.fs);
  C3 c = mix(m.a, m.b, 0.6f * band);
  // Small square motifs in a half-drop repeat inside the light stripes.
  const double row = std::floor(sp.t / (0.7 * P));
  const double shift = std::fmod(row, 2.0) == 0 ? 0 : 0.5 * P;
  const float motif = pulse_train(sp.s + shift, P, 0.68 * P, 0.82 * P, sp.fs) *
                      pulse_train(sp.t, 0.7 * P, 0.28 * P, 0.42 * P, sp.ft);
  c = mix(c, m.b * 0.45f, 0.9f * motif);
  return c * (1 + 0.10f * fbm(sp.s, sp.t, 0.3, 6, m.seed, fpn(sp)));
}

C3 brick(const Material& m, const SurfacePoint& sp) {
  const double h = m.scale, L = 3 * h, mw = 0.14 * h;
  const double fp = fpn(sp);
  const double row = std::floor(sp.t / h);
  const double s2 = sp.s + (std::fmod(std::abs(row), 2.0) == 1 ? 0.5 * L : 0);
  const double col = std::floor(s2 / L);
  const float mortar = 1 - (1 - line_train(sp.t, h, mw, sp.ft)) * (1 - line_train(s2, L, mw, sp.fs));
  const float r = hash01(int64_t(col), int64_t(row), m.seed), g = hash01(int64_t(col), int64_t(row), m.seed + 1);
  C3 b = m.a * (0.72f + 0.5f * r);
  b.x() += 0.08f * (g - 0.5f);
  b = mix(m.a, b, detail_weight(h, fp));
  b *= 1 + 0.12f * fbm(sp.s, sp.t, 0.05, 3, m.seed + 2, fp) + 0.10f * fbm(sp.s, sp.t, 1.5, 3, m.seed + 3, fp);
  return mix(b, m.b, mortar);
}

C3 wood(const Material& m, const SurfacePoint& sp) {
  const double W = m.scale, Lp = 8 * W;
  const double fp = fpn(sp);
  const double j = std::floor(sp.t / W);
  const double off = hash01(int64_t(j), 0, m.seed) * Lp;
  const double k = std::floor((sp.s + off) / Lp);
  const float tint = 1 + 0.35f * (hash01(int64_t(j), int64_t(k), m.seed + 1) - 0.5f) * detail_weight(W, fp);
  // Grain: noise stretched along the plank (0.15 across vs 3 along), rings on top of it.
  const double gs = 0.15, gt = 3.0;
  const float g = fbm(sp.s * gs, sp.t * gt + 31 * k, 0.1, 5, m.seed + 2, std::max(sp.fs * gs, sp.ft * gt));
  const float ring_w = detail_weight(1.0 / 60, sp.ft);
  const float rings = ring_w * (0.5f + 0.5f * float(std::sin(2 * M_PI * (sp.t * 60 + 4 * g))));
  C3 c = mix(m.a, m.b, clamp01(0.45f + 0.5f * g + 0.25f * rings)) * tint;
  const float gaps = std::max(line_train(sp.t, W, 0.004, sp.ft), line_train(sp.s + off, Lp, 0.004, sp.fs));
  return mix(c, m.b * 0.35f, gaps);
}

C3 fabric(const Material& m, const SurfacePoint& sp) {
  const double P = m.scale;
  const float cs = pulse_train(sp.s, P, 0, 0.35 * P, sp.fs), ct = pulse_train(sp.t, P, 0, 0.35 * P, sp.ft);
  const float ls = pulse_train(sp.s, P, 0.6 * P, 0.66 * P, sp.fs), lt = pulse_train(sp.t, P, 0.6 * P, 0.66 * P, sp.ft);
  C3 c = mix(m.a, m.b, 0.5f * (cs + ct));
  c = mix(c, C3(0.9f, 0.88f, 0.8f), 0.6f * std::max(ls, lt));
  const double fp = fpn(sp);
  return c * (1 + 0.08f * fbm(sp.s, sp.t, 0.012, 2, m.seed, fp) + 0.1f * fbm(sp.s, sp.t, 0.4, 4, m.seed + 1, fp));
}

C3 tiles(const Material& m, const SurfacePoint& sp) {
  const double T = m.scale, fp = fpn(sp);
  const float joints = std::max(line_train(sp.s, T, 0.012, sp.fs), line_train(sp.t, T, 0.012, sp.ft));
  const float h = hash01(int64_t(std::floor(sp.s / T)), int64_t(std::floor(sp.t / T)), m.seed);
  const float tint = 1 + 0.16f * (h - 0.5f) * detail_weight(T, fp);
  const float speck = fbm(sp.s, sp.t, 0.08, 4, m.seed + 1, fp);
  return mix(m.a * (tint + 0.18f * speck), m.b, joints);
}

C3 poster(const Material& m, const SurfacePoint& sp) {
  const double C = m.scale, fp = fpn(sp);
  const int64_t i = int64_t(std::floor(sp.s / C)), j = int64_t(std::floor(sp.t / C));
  double u0 = i * C, u1 = u0 + C, v0 = j * C, v1 = v0 + C;  // current rectangle, metres
  uint32_t leaf = uint32_t(i * 73856093 ^ j * 19349663);
  float border = 0;
  const double bw = 0.025 * C;
  for (int level = 0; level < 4; ++level) {
    const float h = hash01(int64_t(leaf), level, m.seed), h2 = hash01(int64_t(leaf), level + 9, m.seed);
    if (level > 0 && h < 0.2f) break;
    const bool split_u = (u1 - u0) > (v1 - v0) ? h2 < 0.8f : h2 < 0.2f;
    if (split_u) {
      const double pos = u0 + (0.3 + 0.4 * h) * (u1 - u0);
      border = std::max(border, box_coverage(sp.s - pos, -0.5 * bw, 0.5 * bw, sp.fs));
      (sp.s < pos ? u1 : u0) = pos;
      leaf = leaf * 2 + (sp.s < pos ? 1u : 2u);
    } else {
      const double pos = v0 + (0.3 + 0.4 * h) * (v1 - v0);
      border = std::max(border, box_coverage(sp.t - pos, -0.5 * bw, 0.5 * bw, sp.ft));
      (sp.t < pos ? v1 : v0) = pos;
      leaf = leaf * 2 + (sp.t < pos ? 1u : 2u);
    }
  }
  const float hc = hash01(int64_t(leaf), 77, m.seed), hs = hash01(int64_t(leaf), 78, m.seed);
  C3 c = palette(hc, hs);
  // Some rectangles carry their own fine pattern: stripes, a checker or a gradient.
  const int style = int(hash01(int64_t(leaf), 79, m.seed) * 4);
  if (style == 1) c *= 0.7f + 0.3f * pulse_train(sp.s + sp.t, 0.04, 0, 0.02, std::max(sp.fs, sp.ft) * 1.4);
  if (style == 2) {
    const float a = pulse_train(sp.s, 0.05, 0, 0.025, sp.fs), b = pulse_train(sp.t, 0.05, 0, 0.025, sp.ft);
    c *= 0.65f + 0.35f * (a + b - 2 * a * b);
  }
  if (style == 3) c *= 0.6f + 0.5f * float((sp.t - v0) / std::max(1e-6, v1 - v0));
  c = mix(C3(0.5f, 0.45f, 0.4f), c, detail_weight(std::min(u1 - u0, v1 - v0), fp));
  c *= 1 + 0.08f * fbm(sp.s, sp.t, 0.2, 5, m.seed + 5, fp);
  return mix(c, C3(0.06f, 0.06f, 0.07f), border);
}

C3 books(const Material& m, const SurfacePoint& sp) {
  const double Hs = m.scale, bw = 0.035, fp = fpn(sp);
  const int64_t row = int64_t(std::floor(sp.t / Hs));
  const double ts = sp.t - row * Hs;
  auto boundary = [&](int64_t k) { return k * bw + 0.014 * (hash01(k, row, m.seed) - 0.5); };
  int64_t k = int64_t(std::floor(sp.s / bw));
  if (sp.s < boundary(k)) --k;
  else if (sp.s >= boundary(k + 1)) ++k;
  const float h1 = hash01(k, row, m.seed + 1), h2 = hash01(k, row, m.seed + 2), h3 = hash01(k, row, m.seed + 3);
  const double hb = Hs * (0.55 + 0.38 * h3);
  C3 book = palette(h1, h2);
  const float label = box_coverage(ts, 0.62 * hb, 0.72 * hb, sp.ft) * (h2 > 0.4f ? 1.f : 0.f);
  book = mix(book, C3(0.9f, 0.8f, 0.5f), 0.8f * label);
  const float gap = std::max(box_coverage(sp.s - boundary(k), -0.0015, 0.0015, sp.fs),
                             box_coverage(sp.s - boundary(k + 1), -0.0015, 0.0015, sp.fs));
  book = mix(book, C3(0.05f, 0.04f, 0.03f), gap);
  book = mix(C3(0.45f, 0.35f, 0.3f), book, detail_weight(bw, fp));
  const float inside = box_coverage(ts, 0, hb, sp.ft);
  return mix(m.b, book, inside) * (1 + 0.06f * fbm(sp.s, sp.t, 0.1, 4, m.seed + 4, fp));
}

C3 paint(const Material& m, const SurfacePoint& sp) {
  const double fp = fpn(sp);
  const float n = fbm(sp.s, sp.t, 0.6, 7, m.seed, fp);
  return mix(m.a, m.b, 0.25f * clamp01(0.5f + n)) * (1 + 0.08f * n);
}

}  // namespace chungs::synth::detail
