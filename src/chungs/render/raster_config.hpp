// Settings of the Gaussian rasterizer, with every default in one place.
#pragma once
#include <array>

namespace chungs {

constexpr int kTileSize = 16;  // tiles are 16x16 pixels

struct RasterConfig {
  double near_plane = 0.01;  // metres; Gaussians with view-space z below this are culled
  double low_pass = 0.3;     // px^2 added to the diagonal of every 2D covariance (EWA low-pass)
  // low_pass holds for images of at least this many pixels (620x188). On smaller ones it keeps the
  // solid angle it covers there: x pixels / reference, at least 1/16 (0: low_pass at any size). At
  // 310x94, 0.3 px^2 blurred every splat over 4x the angle and the map scored 0.95-1.40 dB under
  // 620x188 on three streets at 10 steps per keyframe; with the same angle, 0.74-0.93 dB on five
  // (bench/README, issue 20).
  double small_image_reference_px = 620.0 * 188.0;
  // The low-pass widens a splat smaller than a pixel; true scales its opacity by sqrt(det before / det
  // after) so that what it covers keeps its weight (an anti-aliased splat): a Gaussian trained from near
  // views keeps its look from afar instead of growing to a 0.3 px^2 blob of full opacity (2 km street at
  // 620x188: +0.22-0.37 dB held-out in the three pacings, bench/README.md). false: the plain 3DGS low-pass.
  bool antialias = true;
  double alpha_max = 0.99;          // per-splat alpha clamp (keeps 1 - alpha away from zero)
  double min_alpha = 1.0 / 255.0;   // splats fainter than this at a pixel are skipped
  double min_transmittance = 1e-4;  // a pixel stops before the splat that would take T below this
  double extent_sigma = 3.0;        // a splat reaches at most this many standard deviations (ellipse)
  // The Jacobian of the projection is evaluated with the mean clamped to this many half-image-widths
  // around the image centre, so splats far outside the view do not blow up (3DGS uses 1.3).
  double guard_band = 1.3;
  int sh_degree = 3;                                // SH bands evaluated, 0..3
  std::array<double, 3> background{0.0, 0.0, 0.0};  // RGB composited behind the splats
  // GPU only: a tile with more (tile, splat) entries than this is composited in segments of this many, one
  // block each, so that a crowded tile does not hold up the whole image; 0: one block a tile. The
  // segments change the image only by float rounding.
  int segment_entries = 512;

  // Throws Error naming the bad field when a value is out of its range.
  void validate() const;
  // The low-pass, px^2, for an image of that size (see small_image_reference_px).
  double low_pass_for(int width, int height) const;
};

// A configuration without the cut-offs that make the rendered image a piecewise function of the
// parameters (the alpha < 1/255 skip, the transmittance stop, the 3-sigma extent cut; an 8-sigma cut
// remains, where alpha < opacity * 1.3e-14): the finite-difference gradient tests use it so that no
// pixel jumps across a cut-off between the two evaluations of a central difference. It renders the
// faint tails that the default skips, so images differ from the default by up to a few 1/255.
inline RasterConfig smooth_raster_config() {
  RasterConfig c;
  c.min_alpha = 0.0;
  c.min_transmittance = 0.0;
  c.extent_sigma = 8.0;
  return c;
}

}  // namespace chungs
