// Frame-to-frame motion from stereo matches, robust to independently moving objects (issue 23).
//
// The features with depth of the previous and the current frame are matched by descriptor, then
// motions are found one after the other by RANSAC on three 3D-3D matches (sampled among the near,
// reliable points) scored by the reprojection of the previous 3D point into the current left and
// right images: a match whose stereo depth changed differently from the hypothesis' motion is an
// outlier. After a motion is found its inliers are set aside and the next is sought among the rest.
// A lorry crossing ahead gives a motion of its own; the static world is told from it by coverage:
// the static world's inliers spread over the image and over depth (image grid x depth bins), a
// vehicle's gather in one patch at one depth. Features on the other motions are reported as moving.
#pragma once
#include <vector>

#include "chungs/geometry/se3.hpp"
#include "chungs/tracking/features.hpp"
#include "chungs/tracking/reprojection.hpp"

namespace chungs::tracking {

struct FrameMotionOptions {
  int max_motions = 3;        // motions sought one after the other
  int min_inliers = 15;       // a motion needs this many inlier matches
  int iterations = 200;       // RANSAC samples per motion
  float search_radius = 0.3f; // descriptor search window, share of the image width
  int grid_cols = 8, grid_rows = 4;  // coverage cells over the image ...
  double depth_bins[3] = {8, 20, 50};  // ... times depth bins (metres, splits)
  double distinct_translation = 0.15;  // m: a second motion closer than this (and the angle) to the
  double distinct_rotation_deg = 1.5;  //    chosen one is the same world, not a moving object
  // With a predicted motion (constant velocity), a motion further from it than this is not the static world:
  double predict_translation = 0.15;   // m, plus predict_translation_share of the predicted step
  double predict_translation_share = 0.15;
  double predict_rotation_deg = 30;   // loose: a sudden turn is the camera; a moving object shifts (translation)
  float moving_px = 15;                // ... and its inliers that land this far from the prediction are moving
  int whole_view_cells = 16;           // whole_view: this many coverage cells over 3 or more depth bins
  // Without a prediction (start-up), a motion that moves the camera sideways faster than forwards (and more
  // than this many metres) is taken only when no other is left: a camera looking ahead from a vehicle.
  double sideways_limit = 0.3;         // 0: no such preference
};

struct FrameMotion {
  bool ok = false;
  SE3 T_cp;                   // current camera from previous camera, the static world's motion
  int matches = 0;            // descriptor matches with depth on both sides
  int inliers = 0, cells = 0; // of the chosen motion
  int motions = 0;            // motions found (1: nothing else moves)
  int runner_up_cells = 0;    // coverage of the best other distinct motion (0: none)
  int runner_up_inliers = 0;  // most inliers of another distinct motion (0: none)
  bool disagrees = false;     // a prediction was given and no motion found agrees with it
  bool chosen_without_prediction = false;  // more than one distinct motion and no prediction to tell them apart
  // The chosen motion's inliers fill most of the view at several depths (near, mid and far): the static
  // world seen whole, trusted over a prediction it disagrees with (after coasting behind a vehicle).
  bool whole_view = false;
  int depth_bins = 0;         // depth bins with 5 or more of the chosen motion's inliers
  std::vector<char> moving;   // per current feature: an inlier of another, distinct motion
  int moving_features = 0;
};

// `predicted` (optional): the motion constant velocity predicts. The static world is then the
// best-covered motion that agrees with it; without one, the best-covered motion.
FrameMotion estimate_frame_motion(const Features& prev, const Features& cur, const Intrinsics& k, int width,
                                  int height, const FrameMotionOptions& opt = {}, const SE3* predicted = nullptr);

}  // namespace chungs::tracking
