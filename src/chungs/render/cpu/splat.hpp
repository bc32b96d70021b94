// A Gaussian projected to the image: what the per-tile compositing reads, one per rendered index.
#pragma once

namespace chungs::cpu {

template <typename T>
struct Splat {
  T mx = 0, my = 0;         // mean in pixels
  T ca = 0, cb = 0, cc = 0; // conic (inverse 2D covariance): q = ca dx^2 + 2 cb dx dy + cc dy^2
  T opacity = 0;            // sigmoid of the logit
  T power_min = 0;          // a pixel is skipped when -q/2 < power_min (alpha and extent cut-offs)
  T color[3] = {0, 0, 0};   // SH colour + 0.5, clamped at 0
  T z = 0, inv_z = 0;       // view-space depth of the mean and its inverse
  T radius = 0;             // 3 sigma of the major axis, pixels
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;  // inclusive pixel box inside the image; empty when culled

  bool visible() const { return x0 <= x1 && y0 <= y1; }
};

// dLoss/d(splat quantities), accumulated over pixels by the compositing backward; kSplatGrad per splat.
enum SplatGradIndex { kGMx, kGMy, kGCa, kGCb, kGCc, kGOpacity, kGR, kGG, kGB, kGZ, kSplatGrad };

}  // namespace chungs::cpu
