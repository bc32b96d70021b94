// Two-view initialisation of a monocular map (issue 25): the relative pose of two frames and the points
// they both see, from image matches alone. A homography and a fundamental matrix are fitted at the same
// time with RANSAC, one is chosen by how well each explains the matches, its motion hypotheses are told
// apart by triangulation (points in front of both cameras, small reprojection error), points without
// enough parallax are left out, and the two views are refined by bundle adjustment.
//
// Scale: one camera sees no metric scale. The result is scaled so that the median depth of the points in
// the first view is `target_median_depth` (1 by default): the map's unit is "the first keyframe's median
// scene depth", and every later estimate keeps that unit until the map drifts in scale.
#pragma once
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "chungs/geometry/se3.hpp"
#include "chungs/tracking/features.hpp"
#include "chungs/tracking/reprojection.hpp"

namespace chungs::tracking {

struct TwoViewOptions {
  int min_matches = 100;           // matches needed before any model is fitted
  int min_points = 50;             // triangulated points (with the parallax below) needed to accept
  double min_parallax_deg = 1.0;   // a point's two viewing rays must differ by at least this angle
  double homography_ratio = 0.45;  // the homography is taken when S_H / (S_H + S_F) exceeds this
  double ambiguity = 0.75;         // the second-best motion hypothesis must explain fewer points than this share
  double target_median_depth = 1.0;
  int ba_iterations = 20;
  float search_radius = 0.1f;      // matching window, share of the image width
  float scale_factor = 1.2f;       // ORB pyramid step, for the per-level pixel uncertainty
};

enum class TwoViewModel { None, Homography, Fundamental };
const char* model_name(TwoViewModel m);

struct TwoViewResult {
  bool ok = false;
  std::string why;                         // when not ok: what was missing
  TwoViewModel model = TwoViewModel::None;
  double score_h = 0, score_f = 0;         // model scores (see two_view_geometry)
  int matches = 0;                         // correspondences given or found
  SE3 T_21;                                // second camera from first (the first camera is the world)
  std::vector<int> used;                   // indices of the correspondences that became points
  std::vector<Eigen::Vector3d> points;     // in the first camera's frame, same order as `used`
  double median_parallax_deg = 0;
  double scale = 1;                        // factor that brought the median depth to the target
};

// From pixel correspondences (p1[i] in view 1 matches p2[i] in view 2); `octave` (may be empty: all 0) is
// the pyramid level of each match, which widens its pixel uncertainty.
TwoViewResult two_view_geometry(const std::vector<cv::Point2f>& p1, const std::vector<cv::Point2f>& p2,
                                const std::vector<int>& octave, const Intrinsics& k, const TwoViewOptions& opt = {});

// Matches of two frames' ORB features for initialisation: the nearest descriptor within a window around the
// same pixel (the camera moved little), with a ratio test and one match per feature of `b`.
std::vector<std::pair<int, int>> match_for_init(const Features& a, const Features& b, int width, int height,
                                                const TwoViewOptions& opt = {});

// Both steps; `used` then indexes the returned `pairs` (feature of a, feature of b).
TwoViewResult initialize_two_view(const Features& a, const Features& b, const Intrinsics& k, int width, int height,
                                  std::vector<std::pair<int, int>>& pairs, const TwoViewOptions& opt = {});

// Linear triangulation of one point from two world-to-camera poses and normalised image coordinates.
Eigen::Vector3d triangulate(const SE3& T1_cw, const SE3& T2_cw, const Eigen::Vector2d& x1, const Eigen::Vector2d& x2);

}  // namespace chungs::tracking
