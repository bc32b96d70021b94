// Depth of a keyframe seen by one camera (issue 25): the plane sweep (plane_sweep.hpp) against earlier
// keyframes at a grid of the keyframe's pixels, around a dense prior where one exists (the tracker's
// map points densified, or a learned model's prediction aligned to them), then spread to every pixel
// by the same edge-aware densification the prior uses (prior_densify.hpp), with a confidence that
// drops what no confident sample of the pixel's own surface reaches.
//
// Why a grid and not every pixel: on the host a sweep costs ~0.3 ms a pixel (a dense half-size KITTI
// keyframe took 40 s), while the sampler draws a few per cent of the pixels and puts a Gaussian of
// several pixels at each; the edge-aware spread keeps depth steps at image edges between grid points.
// On the GPU the grid can be every pixel (cuda_stride).
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "chungs/depth/plane_sweep.hpp"
#include "chungs/depth/prior_densify.hpp"

namespace chungs {

// Where a keyframe's dense prior comes from. The default densifies the map points seen by the
// keyframe (MapPointPrior); a learned model (--mono-depth-model, depth/learned_*) plugs in here as a
// source that predicts a relative inverse depth from the image and aligns it to the same points by
// a median/MAD fit in inverse depth. prior() is called from several loader threads at once.
class DepthPriorSource {
 public:
  virtual ~DepthPriorSource() = default;
  virtual std::string name() const = 0;
  // A dense prior (inverse depth in the points' units, 0 where none, and a confidence) for `image`,
  // given the sparse depths seen in it (may be few or none); nothing when it cannot give one.
  virtual std::optional<DensePrior> prior(const Image8& image, const std::vector<DepthSample>& points) const = 0;
};

// The tracker's map points projected into the keyframe, densified edge-aware; none below min_points.
class MapPointPrior : public DepthPriorSource {
 public:
  MapPointPrior(size_t min_points, DensifyConfig densify) : min_points_(min_points), densify_(densify) {}
  std::string name() const override { return "map points"; }
  std::optional<DensePrior> prior(const Image8& image, const std::vector<DepthSample>& points) const override;

 private:
  size_t min_points_;
  DensifyConfig densify_;
};

struct MultiviewDepthConfig {
  int stride = 4;       // host: sweep every stride-th pixel per axis (then spread edge-aware)
  int cuda_stride = 1;  // under --device cuda
  // Keyframes swept against (best first, select_sweep_neighbours), the paper's 6: against 4, held-out
  // +0.9 dB on Replica office0, +0.4 on KITTI, +0.3 on a street from one camera, the room unchanged
  // (bench/README.md), for a sweep 1.5x as long.
  size_t neighbours = 6;
  size_t min_prior_points = 20;  // map points in view below which there is no prior (the sweep goes wide)
  // Spread depth is kept where its confidence (prior_densify's, from the swept samples' support) is
  // at least this: pixels far from any confident sample of their own surface get none (indoors the
  // membrane fill gives them depth). 0.25 kept untextured surfaces between edges that 0.5 left empty
  // before that fill existed (+1.0 dB held-out on KITTI, +2.9 on Replica office0); with the fill and the
  // second pass, 0.4 scored +0.1 to +0.4 dB over 0.25 on the room, Replica and KITTI (bench/README.md).
  double min_confidence = 0.4;
  int keep_keyframes = 24;  // recent keyframes whose images the run keeps for the sweep
  // A keyframe's guessed pixels are swept again in the load of the keyframe this many later, with the
  // keyframes after it among the candidates: what only later views see (the side a camera turns to)
  // then gets depth, which replaces the guesses in the keyframe's depth target and moves the
  // Gaussians placed at them (Mapper::redepth). 0: never. 2 scored +0.6 dB held-out on Replica office0
  // and the room from one camera, 1 nothing (bench/README.md).
  int refresh_after = 2;
  // A second pass: the first pass's matches of at least this confidence (with the map points), spread
  // edge-aware, are the prior of a narrow sweep at the grid pixels the first pass swept wide, and its
  // result replaces theirs. A wide sweep's winner is often a repeated texture's other copy; the
  // surface's confident matches around it say where to look. 0: one pass. On the GPU, against one
  // pass: held-out +0.5 dB on Replica and KITTI, +0.3 on 400 m streets, the room within its spread.
  double anchor_confidence = 0.7;
  // ... spread on the image reduced to at most this many pixels across: it only says where the narrow
  // sweep looks, and spread at full size it cost more than the sweep itself on the GPU (1241x376: 2.6 s
  // a keyframe, 1.1 s reduced, held-out PSNR the same or higher; bench/README.md).
  int anchor_width = 320;
  // Pixels left without depth get the edge-aware spread's depth however unsure (from one camera,
  // Replica office0 +0.58 dB held-out and the room +0.35 over three seeds, bench/README.md), and
  // where it has none the membrane interpolation of the others in inverse depth (hole_fill.hpp), so
  // that untextured walls get Gaussians. run turns it off where the sampler has a fill depth
  // (outdoors), since there they are mostly sky.
  bool fill_holes = true;
  // Whether the fill's depth also serves as the depth loss's target. Off: it only places Gaussians (the
  // keyframe's depth holds it negated, sampler.hpp), the loss scores the render against swept depth
  // only. On the CPU, off: Replica office0 from one camera +0.69 dB held-out (a third to a half of its
  // pixels are filled: sofa, walls, the image's borders), the synthetic room -0.29 (its fill is mostly
  // flat walls, where the guess is good) (bench/README.md).
  bool supervise_fill = false;
  // RGB-D and stereo input: the depth of each pixel the sampler draws is polished by the sweep against
  // `refine_neighbours` earlier keyframes over its inverse depth -+ the range (1/m; the paper's ranges) where
  // the sweep is confident (depth_refine.hpp). On: held-out +0.29 dB on KITTI stereo with ground-truth
  // poses, +0.08 tracked, +0.21 on the synthetic RGB-D room, two CPU runs each (bench/README.md). run
  // skips it under anytime pacing, where its time would come out of the optimiser's steps.
  bool refine = true;
  size_t refine_neighbours = 4;  // keyframes the refinement sweeps against (measured with 4)
  double refine_rgbd_range = 0.05, refine_stereo_range = 0.01;
  PlaneSweepConfig sweep;
  NeighbourChoice choice;
  DensifyConfig densify;
  void validate() const;
};

struct MultiviewDepthInput {
  Camera camera;  // the keyframe's and every neighbour's (one camera), undistorted
  SweepView reference;
  std::vector<SweepView> neighbours;  // 1 .. 8 (fewer than `neighbours` when fewer qualified)
  std::vector<DepthSample> points;    // sparse depths in the reference (map points), the poses' units
  // Map units per metre (1 for metric poses; a monocular tracker's unit is its first keyframe's median
  // depth): sweep.near / far are metres and are scaled by it.
  double units_per_metre = 1.0;
  // The reference's depth made before (MultiviewDepth::depth: negative where the fill guessed): the
  // guesses are swept again, now against these neighbours, with the measured pixels as anchors. The
  // result holds depth only at guessed pixels the sweep and spread now give depth (0 elsewhere, no fill).
  const ImageF* again = nullptr;
};

struct MultiviewDepth {
  // The poses' units along the optical axis, 0 where invalid, negated where only the fill guessed it
  // and config.supervise_fill is off; the reference's size.
  ImageF depth;
  ImageF confidence;  // (0, 1] where valid
  size_t swept = 0, matched = 0, valid = 0;  // grid pixels swept, of them given depth, pixels with depth
  size_t reswept = 0;                        // grid pixels swept again around the first pass's anchors
  size_t filled = 0;                         // pixels given depth by fill_holes (not in valid)
  bool prior = false;  // whether a prior narrowed the sweep
};

// Throws Error on bad configuration or inputs (plane_sweep.hpp's checks). `prior_source` may be null:
// no prior, the wide sweep everywhere. The grid's stride is config.cuda_stride when sweep.cuda.
MultiviewDepth multiview_depth(const MultiviewDepthInput& input, const MultiviewDepthConfig& config,
                               const DepthPriorSource* prior_source);

// Map points (world) seen in a view: those in front of the camera and inside the image, as depth samples.
std::vector<DepthSample> project_points(const std::vector<Eigen::Vector3d>& world, const Camera& camera,
                                        const SE3& T_wc);

}  // namespace chungs
