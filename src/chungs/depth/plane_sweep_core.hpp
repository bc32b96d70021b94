// The per-pixel work of the plane sweep (plane_sweep.hpp), written once for the CPU loop and the
// CUDA kernel (depth/cuda/plane_sweep.cu) so that both compute the same numbers bit for bit: plain
// float arithmetic in one fixed order through the helpers below. nvcc would otherwise fuse a*b+c into
// one FMA (a different rounding); the host build targets baseline x86-64, which has no FMA to fuse
// into. Keep every expression here routed through mul/add/sub/div/root.
//
// Cost: 1 - ZNCC of a (2r+1)^2 patch, a fronto-parallel plane per hypothesis. ZNCC rather than census:
// keyframes seconds apart differ in exposure (KITTI's auto gain), which ZNCC ignores by construction,
// and its value on a bounded scale (a correlation) gives the uniqueness test and the confidence a
// meaning that does not depend on the texture's contrast; the patch's own variance tells a
// textureless reference patch apart before any matching.
#pragma once
#include <cmath>
#include <cstdint>

#ifdef __CUDACC__
#define CHUNGS_PS_HD __host__ __device__
#else
#define CHUNGS_PS_HD
#endif

namespace chungs::plane_sweep {

constexpr int kMaxNeighbours = 8;
constexpr int kMaxHypotheses = 256;
constexpr int kMaxPatchRadius = 3;
constexpr int kMaxPatch = (2 * kMaxPatchRadius + 1) * (2 * kMaxPatchRadius + 1);
constexpr float kNoCost = 2.0f;  // a hypothesis too few neighbours see: worse than any 1 - ZNCC

CHUNGS_PS_HD inline float mul(float a, float b) {
#ifdef __CUDA_ARCH__
  return __fmul_rn(a, b);
#else
  return a * b;
#endif
}
CHUNGS_PS_HD inline float add(float a, float b) {
#ifdef __CUDA_ARCH__
  return __fadd_rn(a, b);
#else
  return a + b;
#endif
}
CHUNGS_PS_HD inline float sub(float a, float b) {
#ifdef __CUDA_ARCH__
  return __fsub_rn(a, b);
#else
  return a - b;
#endif
}
CHUNGS_PS_HD inline float div(float a, float b) {
#ifdef __CUDA_ARCH__
  return __fdiv_rn(a, b);
#else
  return a / b;
#endif
}
CHUNGS_PS_HD inline float root(float a) {
#ifdef __CUDA_ARCH__
  return __fsqrt_rn(a);
#else
  return std::sqrt(a);
#endif
}

// Homogeneous pixel of a reference pixel (x, y) at inverse depth rho in a neighbour:
// h = H (x, y, 1) + rho e, with H = K_n R_nr K_r^-1 and e = K_n t_nr.
struct Neighbour {
  float H[9];
  float e[3];
  const float* image;  // gray levels 0..255, row-major, the reference's size
};

struct Problem {
  int width = 0, height = 0;
  const float* ref = nullptr;
  Neighbour nb[kMaxNeighbours];
  int neighbours = 0;
  int radius = 3;
  int best_k = 3;
  int min_views = 1;  // a patch seen by fewer than best_k neighbours scores over those that see it, down to this many
  float inv_near = 2.0f, inv_far = 0.0125f;  // the wide sweep, 1/m
  float prior_range = 0.2f;                   // the narrow sweep: prior * (1 -+ range)
  float prior_abs_range = 0.0f;  // > 0: the narrow sweep is prior -+ this instead, inside [inv_far, inv_near]
  float min_prior_confidence = 0.5f;
  float step_px = 1.0f;  // hypotheses spaced so the widest-moving neighbour moves about this far
  int min_hypotheses = 16, max_hypotheses = 192;
  float min_texture2 = 4.0f;  // variance of the reference patch below which it is textureless
  float max_cost = 0.4f;
  float uniqueness_margin = 0.1f;
  float exclusion_px = 2.0f;  // minima closer than this to the winner belong to its basin
  float max_rel_per_px = 0.1f;  // relative depth change per pixel of image motion at the winner
};

struct PixelResult {
  float depth = 0, confidence = 0;
};

// The homogeneous point as a division makes it a pixel; false behind the neighbour.
CHUNGS_PS_HD inline bool dehomogenise(float hx, float hy, float hz, float& u, float& v) {
  if (!(hz > 1e-6f)) return false;
  u = div(hx, hz), v = div(hy, hz);
  return true;
}

// Row k of H (x, y, 1): the part of a homogeneous coordinate that does not depend on the plane.
CHUNGS_PS_HD inline float h_row(const Neighbour& n, int k, float x, float y) {
  return add(add(mul(n.H[3 * k], x), mul(n.H[3 * k + 1], y)), n.H[3 * k + 2]);
}

// Projects (x, y) at inverse depth rho into neighbour n; false behind it.
CHUNGS_PS_HD inline bool project(const Neighbour& n, float x, float y, float rho, float& u, float& v) {
  return dehomogenise(add(h_row(n, 0, x, y), mul(rho, n.e[0])), add(h_row(n, 1, x, y), mul(rho, n.e[1])),
                      add(h_row(n, 2, x, y), mul(rho, n.e[2])), u, v);
}

// On the host, the plane-free parts of a patch's homogeneous coordinates in each neighbour are worked out
// once per pixel (`rows`: 3 per patch pixel, kMaxPatch pixels per neighbour) instead of once per
// hypothesis; every hypothesis then adds its plane's term, so the sums are those of project() to the
// bit. On the GPU such a table would live in local memory, so the kernel projects directly.
CHUNGS_PS_HD inline void patch_rows(const Neighbour& n, int x, int y, int r, float* rows) {
  int i = 0;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx, ++i)
      for (int k = 0; k < 3; ++k) rows[3 * i + k] = h_row(n, k, float(x + dx), float(y + dy));
}

// 1 - ZNCC between the centred reference patch `rc` (norm rnorm) and neighbour n's patch on the plane
// of inverse depth rho; kNoCost where a sample falls outside the neighbour or behind it. `rows`: the
// patch's patch_rows() in n, or null to work them out here (as project() does).
CHUNGS_PS_HD inline float patch_cost(const Problem& p, const Neighbour& n, int x, int y, float rho, const float* rc,
                                     float rnorm, float ref_mean, const float* rows) {
  const int r = p.radius, side = 2 * r + 1;
  const float count = float(side * side);
  const float re0 = mul(rho, n.e[0]), re1 = mul(rho, n.e[1]), re2 = mul(rho, n.e[2]);
  float s = 0, s2 = 0, sc = 0;
  int i = 0;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx, ++i) {
      const float X = float(x + dx), Y = float(y + dy);
      const auto plane_free = [&](int k) { return rows ? rows[3 * i + k] : h_row(n, k, X, Y); };
      float u, v;
      if (!dehomogenise(add(plane_free(0), re0), add(plane_free(1), re1), add(plane_free(2), re2), u, v))
        return kNoCost;
      if (!(u >= 0.0f && v >= 0.0f && u < float(p.width - 1) && v < float(p.height - 1))) return kNoCost;
      const float fu = floorf(u), fv = floorf(v);
      const int iu = int(fu), iv = int(fv);
      const float au = sub(u, fu), av = sub(v, fv);
      const float* row = n.image + size_t(iv) * size_t(p.width) + iu;
      const float top = add(row[0], mul(au, sub(row[1], row[0])));
      const float bot = add(row[p.width], mul(au, sub(row[p.width + 1], row[p.width])));
      // Offset by the reference mean: the sums stay small, so the variance below keeps its digits.
      const float g = sub(add(top, mul(av, sub(bot, top))), ref_mean);
      s = add(s, g), s2 = add(s2, mul(g, g)), sc = add(sc, mul(rc[i], g));
    }
  const float var = sub(s2, div(mul(s, s), count));  // count x the neighbour patch's variance
  // A flat neighbour patch matches nothing: no correlation rather than a division by ~0.
  if (!(var > mul(mul(count, p.min_texture2), 0.25f))) return 1.0f;
  return sub(1.0f, div(sc, mul(rnorm, root(var))));
}

// Aggregated cost of one hypothesis: the mean of the best_k neighbour costs (occlusion in the
// others does not count); where fewer neighbours see the patch, the mean of those that do, kNoCost
// below min_views of them.
CHUNGS_PS_HD inline float hypothesis_cost(const Problem& p, int x, int y, float rho, const float* rc, float rnorm,
                                          float ref_mean, const float* rows) {
  const int k = p.best_k < p.neighbours ? p.best_k : p.neighbours;
  float best[kMaxNeighbours];
  int have = 0;
  for (int j = 0; j < p.neighbours; ++j) {
    const float c =
        patch_cost(p, p.nb[j], x, y, rho, rc, rnorm, ref_mean, rows ? rows + 3 * kMaxPatch * j : nullptr);
    if (c >= kNoCost) continue;
    // Insertion into the sorted best list (ascending, stable).
    int at = have < k ? have : k;
    while (at > 0 && best[at - 1] > c) {
      if (at < k) best[at] = best[at - 1];
      --at;
    }
    if (at < k) best[at] = c;
    if (have < k) ++have;
  }
  if (have == 0 || have < (p.min_views < k ? p.min_views : k)) return kNoCost;
  float sum = 0;
  for (int j = 0; j < have; ++j) sum = add(sum, best[j]);
  return div(sum, float(have));
}

// The guide neighbour's epipolar segment: position start + t/last * delta along one image axis,
// and the homogeneous terms that turn a position back into inverse depth.
struct Guide {
  float span, start, delta, last;
  float h, hz, e, ez;
  bool along_x;
};

// Inverse depth whose image in the guide lies at hypothesis position t (0 .. last, fractional for the
// sub-step): the position's axis coordinate c solves c (hz + rho ez) = h + rho e.
CHUNGS_PS_HD inline float guide_rho(const Guide& g, float t) {
  const float c = add(g.start, mul(div(t, g.last), g.delta));
  return div(sub(mul(c, g.hz), g.h), sub(g.e, mul(c, g.ez)));
}

// The sweep at one reference pixel. prior_inv: the prior's inverse depth (0: none); `costs` is
// scratch for kMaxHypotheses values.
CHUNGS_PS_HD inline PixelResult sweep_pixel(const Problem& p, int x, int y, float prior_inv, float prior_conf,
                                            float* costs) {
  PixelResult out;
  const int r = p.radius;
  if (x < r || y < r || x >= p.width - r || y >= p.height - r) return out;
  const int side = 2 * r + 1, n = side * side;
  float rc[kMaxPatch];
  float s = 0;
  int i = 0;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx, ++i) {
      rc[i] = p.ref[size_t(y + dy) * size_t(p.width) + (x + dx)];
      s = add(s, rc[i]);
    }
  const float mean = div(s, float(n));
  float ss = 0;
  for (i = 0; i < n; ++i) {
    rc[i] = sub(rc[i], mean);
    ss = add(ss, mul(rc[i], rc[i]));
  }
  if (!(ss >= mul(float(n), p.min_texture2))) return out;  // textureless: no match means anything
  const float rnorm = root(ss);

  const bool narrow = prior_inv > 0.0f && prior_conf >= p.min_prior_confidence;
  float lo = narrow ? mul(prior_inv, sub(1.0f, p.prior_range)) : p.inv_far;
  float hi = narrow ? mul(prior_inv, add(1.0f, p.prior_range)) : p.inv_near;
  if (narrow && p.prior_abs_range > 0.0f) {
    // A measured depth (RGB-D, stereo) is off by a band of inverse depth, not by a share of it; the
    // band stops at the sweep's near and far (a far measurement's band would reach past infinity).
    lo = sub(prior_inv, p.prior_abs_range), hi = add(prior_inv, p.prior_abs_range);
    if (lo < p.inv_far) lo = p.inv_far;
    if (hi > p.inv_near) hi = p.inv_near;
    if (!(hi > lo)) return out;
  }
  // Spacing: hypotheses evenly spaced along the range's image in the neighbour where it is longest
  // (the guide), not evenly in inverse depth: with motion along the optical axis the image moves
  // many times faster per unit of inverse depth at one end of the range than at the other.
  Guide g;
  g.span = 0;
  for (int j = 0; j < p.neighbours; ++j) {
    // A neighbour ahead of the reference cannot see what lies between them: its segment ends where
    // the point would come within half its depth of the neighbour's image plane.
    const Neighbour& nj = p.nb[j];
    float top = hi;
    if (nj.e[2] < 0.0f) {
      const float hz0 = add(add(mul(nj.H[6], float(x)), mul(nj.H[7], float(y))), nj.H[8]);
      const float lim = mul(0.5f, div(hz0, -nj.e[2]));
      if (lim < top) top = lim;
    }
    if (!(top > lo)) continue;
    float u0, v0, u1, v1;
    if (!project(nj, float(x), float(y), lo, u0, v0) || !project(nj, float(x), float(y), top, u1, v1)) continue;
    const float du = sub(u1, u0), dv = sub(v1, v0);
    const float len = root(add(mul(du, du), mul(dv, dv)));
    if (len > g.span) {
      const Neighbour& n = p.nb[j];
      g.span = len;
      g.along_x = (du < 0.0f ? -du : du) >= (dv < 0.0f ? -dv : dv);
      g.start = g.along_x ? u0 : v0, g.delta = g.along_x ? du : dv;
      const int r0 = g.along_x ? 0 : 3;
      g.h = add(add(mul(n.H[r0], float(x)), mul(n.H[r0 + 1], float(y))), n.H[r0 + 2]);
      g.hz = add(add(mul(n.H[6], float(x)), mul(n.H[7], float(y))), n.H[8]);
      g.e = n.e[g.along_x ? 0 : 1], g.ez = n.e[2];
    }
  }
  if (!(g.span > 0.0f)) return out;
  const float want = ceilf(div(g.span, p.step_px));
  int count = want > float(p.max_hypotheses - 1) ? p.max_hypotheses : int(want) + 1;
  if (count < p.min_hypotheses) count = p.min_hypotheses;
  g.last = float(count - 1);

#ifdef __CUDA_ARCH__
  const float* rows = nullptr;
#else
  float rows[3 * kMaxPatch * kMaxNeighbours];
  for (int j = 0; j < p.neighbours; ++j) patch_rows(p.nb[j], x, y, r, rows + 3 * kMaxPatch * j);
#endif
  int best = 0;
  for (i = 0; i < count; ++i) {
    const float rho_i = guide_rho(g, float(i));
    costs[i] = rho_i > 0.0f ? hypothesis_cost(p, x, y, rho_i, rc, rnorm, mean, rows) : kNoCost;
    if (costs[i] < costs[best]) best = i;
  }
  const float cbest = costs[best];
  // The winner must be a good match and inside the range (at an end the minimum may lie beyond).
  if (!(cbest <= p.max_cost) || best == 0 || best == count - 1) return out;

  // Uniqueness: any other local minimum, beyond the winner's basin, must cost clearly more. Without
  // one, the curve's highest cost stands in (the paper's max-versus-min contrast).
  const float px_per_step = div(g.span, g.last);
  const float band = ceilf(div(p.exclusion_px, px_per_step));
  const int excl = band < 1.0f ? 1 : band > float(count) ? count : int(band);
  float other = -1.0f, highest = cbest;
  for (i = 0; i < count; ++i) {
    if (costs[i] > highest) highest = costs[i];
    const int d = i > best ? i - best : best - i;
    if (d <= excl) continue;
    const bool minimum = (i == 0 || costs[i] <= costs[i - 1]) && (i == count - 1 || costs[i] <= costs[i + 1]);
    if (minimum && (other < 0.0f || costs[i] < other)) other = costs[i];
  }
  if (other < 0.0f) other = highest;
  const float gap = sub(other, cbest);
  if (!(gap >= p.uniqueness_margin)) return out;

  // Sub-step: the parabola through the winner and its two neighbours.
  const float a = costs[best - 1], c = costs[best + 1];
  const float den = sub(add(a, c), mul(2.0f, cbest));
  float off = den > 0.0f ? div(sub(a, c), mul(2.0f, den)) : 0.0f;
  off = off > 0.5f ? 0.5f : off < -0.5f ? -0.5f : off;
  const float rho = guide_rho(g, add(float(best), off));
  if (!(rho > 0.0f)) return out;
  // Parallax: where a pixel of image motion spans much depth (near the epipole, short baselines) a
  // good match still says little.
  const float rho_a = guide_rho(g, sub(float(best), 0.5f)), rho_b = guide_rho(g, add(float(best), 0.5f));
  const float per_px = div(sub(rho_b, rho_a), px_per_step);
  if (!((per_px < 0.0f ? -per_px : per_px) <= mul(p.max_rel_per_px, rho))) return out;
  out.depth = div(1.0f, rho);
  const float distinct = div(gap, mul(3.0f, p.uniqueness_margin));
  out.confidence = mul(sub(1.0f, cbest), distinct > 1.0f ? 1.0f : distinct);
  return out;
}

}  // namespace chungs::plane_sweep
