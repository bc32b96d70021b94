// A Gaussian projected to the image: what the per-tile compositing reads, one per rendered index.
#pragma once
#include <cmath>

namespace chungs::cpu {

template <typename T>
struct Splat {
  T mx = 0, my = 0;          // mean in pixels
  T ca = 0, cb = 0, cc = 0;  // conic (inverse 2D covariance): q = ca dx^2 + 2 cb dx dy + cc dy^2
  T opacity = 0;             // sigmoid of the logit
  T power_min = 0;           // a pixel is skipped when -q/2 < power_min (alpha and extent cut-offs)
  T color[3] = {0, 0, 0};    // SH colour + 0.5, clamped at 0
  T z = 0, inv_z = 0;        // view-space depth of the mean and its inverse
  T radius = 0;              // 3 sigma of the major axis, pixels
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;  // inclusive pixel box inside the image; empty when culled

  bool visible() const { return x0 <= x1 && y0 <= y1; }

  // Pixels of row y (offset dy = y - my) inside the cut-off ellipse -q/2 >= power_min, clipped to
  // [lo, hi]: solves ca dx^2 + 2 cb dy dx + cc dy^2 <= -2 power_min for dx. The caller still tests
  // each pixel (rounding at the ellipse edge), so the span only has to contain the ellipse's pixels;
  // it is widened by a hair for that. Returns false when the row misses the ellipse.
  bool row_span(T dy, int lo, int hi, int& xs, int& xe) const {
    const T qmax = -2 * power_min;
    const T bdy = cb * dy;
    const T disc = bdy * bdy - ca * (cc * dy * dy - qmax);
    if (!(disc >= 0)) return false;
    const T r = std::sqrt(disc) / ca, c = mx - bdy / ca;
    const T slack = T(1e-4) * (T(1) + std::abs(c));
    const T a = std::ceil(c - r - slack), b = std::floor(c + r + slack);
    if (!(a <= T(hi) && b >= T(lo))) return false;
    xs = a > T(lo) ? int(a) : lo;
    xe = b < T(hi) ? int(b) : hi;
    return xs <= xe;
  }
};

// dLoss/d(splat quantities), accumulated over pixels by the compositing backward; kSplatGrad per splat.
enum SplatGradIndex { kGMx, kGMy, kGCa, kGCb, kGCc, kGOpacity, kGR, kGG, kGB, kGZ, kSplatGrad };

}  // namespace chungs::cpu
