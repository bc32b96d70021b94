// Depth of a keyframe from its neighbouring keyframes, without learned weights: a plane sweep in
// inverse depth with a 1 - ZNCC patch cost (plane_sweep_core.hpp says why ZNCC), aggregated over the
// best neighbours, a uniqueness test, a parabolic sub-step and a confidence. Around a dense prior
// (prior_densify.hpp) where it is confident, else a wide sweep between near and far.
//
// Stereo rectification cannot serve here: forward motion puts the epipole inside the image. The
// sweep works in the reference's pixels and projects each hypothesis into every neighbour.
//
// The CPU loops are the reference; config.cuda runs the same per-pixel function on the GPU
// (depth/cuda/plane_sweep_cuda.hpp) with bit-identical results.
#pragma once
#include <cstddef>
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

struct PlaneSweepConfig {
  int patch_radius = 3;      // 7x7: 5x5 is too ambiguous on KITTI's asphalt and foliage
  // Neighbour costs averaged per hypothesis (the best ones; fewer when fewer neighbours): 3 of 4 kept
  // more pixels and fewer gross errors than 2 of 4 on the street and KITTI (bench/README.md).
  int best_k = 3;
  // Fewest neighbours that must see a patch: where fewer than best_k do, the mean is over those
  // that do. 1: what only one earlier keyframe saw (the side a camera turns from, the edge of its
  // view) still gets depth; requiring 3 left a third of Replica's views to the fill (bench/README.md).
  int min_views = 1;
  double near = 0.5, far = 80.0;  // metres: the wide sweep where no confident prior exists
  double prior_range = 0.2;  // narrow sweep: prior inverse depth x (1 -+ range) (the paper: 0.2 mono)
  // > 0: the narrow sweep is the prior's inverse depth -+ this instead (1 / the poses' unit), clipped
  // to [1/far, 1/near]: the refinement of measured depth (depth_refine.hpp; the paper: 0.05 RGB-D,
  // 0.01 stereo, in 1/m).
  double prior_abs_range = 0;
  double min_prior_confidence = 0.5;
  double step_px = 1.0;      // hypothesis spacing, in pixels of the neighbour where the range is longest
  int min_hypotheses = 16, max_hypotheses = 192;  // per pixel (the paper: 16 around a prior)
  double min_texture = 2.0;  // gray levels: reference patches with a lower standard deviation are dropped
  double max_cost = 0.4;     // the winner's 1 - ZNCC must be at most this
  // The best other local minimum (more than exclusion_px away in the image) must cost this much more
  // than the winner, in 1 - ZNCC units: a correlation of 0.9 against 0.8 is a choice, against 0.85 not.
  double uniqueness_margin = 0.1;
  double exclusion_px = 2.0;
  // Parallax test: the depth may change by at most this fraction per pixel of motion in the neighbour
  // where the range is longest (near the epipole of forward motion a perfect match is still no depth).
  double max_rel_per_px = 0.1;
  bool cuda = false;  // run on the GPU (CUDA builds only)
  void validate() const;
};

struct SweepView {
  const Image8* image = nullptr;  // gray or RGB; every view has the reference camera's size
  SE3 T_wc;                       // camera-to-world
};

struct PlaneSweepInput {
  Camera camera;  // shared by all views, distortion removed
  SweepView reference;
  std::vector<SweepView> neighbours;         // 1 .. 8
  const ImageF* prior_inv_depth = nullptr;   // 1/m, 0 where none; the reference's size
  const ImageF* prior_confidence = nullptr;  // [0, 1]; without it a positive prior counts as confident
};

struct PlaneSweepDepth {
  ImageF depth;       // metres along the optical axis, 0 where invalid
  ImageF confidence;  // (0, 1] where valid, 0 where invalid
  size_t valid = 0;
};

struct SweepPixel {
  int x = 0, y = 0;
};
struct SweepSample {
  float depth = 0, confidence = 0;  // 0: invalid
};

// Throws Error on bad configuration, missing or mis-sized images or priors, no neighbours or too many,
// a distorted camera, a requested pixel outside the image, or cuda asked for without a CUDA build.
PlaneSweepDepth plane_sweep_dense(const PlaneSweepInput& input, const PlaneSweepConfig& config = {});
std::vector<SweepSample> plane_sweep_at(const PlaneSweepInput& input, const std::vector<SweepPixel>& pixels,
                                        const PlaneSweepConfig& config = {});

// Neighbour keyframes for a plane sweep: those that see much of what the reference sees (overlap of
// a grid of reference pixels placed at scene_depth) with a useful triangulation angle there (the mean
// over the grid points both see, so forward motion counts by its parallax towards the borders).
struct NeighbourChoice {
  size_t count = 6;           // the paper's 6 neighbours
  double scene_depth = 10.0;  // metres: a typical depth of the reference's view
  double min_angle_deg = 0.5;     // closer baselines triangulate nothing
  double target_angle_deg = 5.0;  // score rises to here and falls beyond (perspective distortion)
  double max_axis_angle_deg = 40.0;  // between optical axes
  double min_overlap = 0.3;       // fraction of the grid seen by the candidate
};
// Indices into poses (camera-to-world), best first, never ref itself; fewer than count when fewer
// qualify. Throws Error on ref out of range or a bad choice.
std::vector<size_t> select_sweep_neighbours(const Camera& camera, const std::vector<SE3>& poses, size_t ref,
                                            const NeighbourChoice& choice = {});

}  // namespace chungs
