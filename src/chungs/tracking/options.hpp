// Settings of the visual tracker, with their defaults in one place.
#pragma once
#include "chungs/tracking/features.hpp"
#include "chungs/tracking/loop_closer.hpp"
#include "chungs/tracking/matcher.hpp"
#include "chungs/tracking/mono_init.hpp"
#include "chungs/tracking/stereo_matcher.hpp"

namespace chungs::tracking {

struct TrackerOptions {
  OrbOptions orb;
  StereoOptions stereo;
  // RGB-D depth enters as the stereo residual's third row through a virtual baseline b. A depth error
  // sigma_z = k * z^2 moves the virtual right column by fx * b * k pixels at every depth, so b = 1 / (fx * k)
  // weights the depth row like a pixel. (A fixed 8 cm made depth 10x weaker than the pixels at 320x240:
  // bundle adjustment then re-triangulated points from short baselines and made the room 2.5x worse.)
  double rgbd_depth_noise = 0.003;      // k in 1/m (Kinect-like: 1.2 cm at 2 m)
  double rgbd_virtual_baseline = 0;     // metres; > 0 overrides the one derived from rgbd_depth_noise
  double close_depth_baselines = 40;    // depths below this many baselines count as reliable ("close")
  double rgbd_close_depth = 4.0;        // metres, the same for RGB-D
  int min_init_points = 50;             // features with depth needed to start the map
  int min_inliers = 20;                 // below this, tracking falls back to PnP, then relocalisation
  double motion_check_ratio = 0.4;     // motion-model inliers below this share of the last frame's: try PnP too
  float keyframe_ratio = 0.75f;         // new keyframe when tracked < ratio * reference keyframe's points seen 3 times
  float keyframe_all_ratio = 0.5f;      // ... or tracked < this * all the reference keyframe's points
  int min_keyframe_interval = 0;        // frames after a keyframe before a non-weak frame may be one
  int max_keyframe_interval = 0;        // a keyframe at least every this many frames (0: no limit)
  int local_keyframes = 12;             // covisible keyframes whose points form the local map
  bool local_ba = true;
  int ba_window = 8;                    // keyframes optimised by local bundle adjustment
  int ba_iterations = 10;
  bool cull_keyframes = true;
  bool loop_closure = true;
  // Moving objects and doubtful estimates (issue 23).
  int max_coast_frames = 5;             // frames a prediction may stand in when the static world is not measured
  int confident_inliers = 40;           // fewer local-map inliers make a pose doubtful
  double max_speed = 40;                // m/s; a faster step is implausible (doubtful)
  double max_turn_rate = 180;           // degrees/s; likewise
  double max_sideways_speed = 3;        // m/s; moving sideways faster than this and than forwards is implausible
  LoopOptions loop;
  // Monocular input (issue 25).
  TwoViewOptions mono_init;              // two-view initialisation; its target_median_depth sets the map's unit
  int mono_init_max_frames = 20;         // an initialisation reference older than this many frames is replaced
  int mono_min_inliers = 15;             // tracked map points needed (fewer: lost)
  float mono_keyframe_ratio = 0.75f;     // new keyframe when tracked < ratio * the reference's confirmed points
  int mono_max_keyframe_interval = 8;    // ... or this many frames after the last (0: no limit)
  int mono_min_keyframe_interval = 1;    // frames after a keyframe before the next, unless tracking weakens
                                         // (3 lost the map at tight corners, and gave the mapper half the views)
  int mono_ba_window = 8;                // keyframes optimised by local BA
  int mono_neighbours = 10;              // keyframes new points are triangulated against
  double mono_point_parallax_deg = 1.0;  // least parallax of a new point's two rays
  bool mono_relocalise = true;           // after a loss, try the existing map before starting a new segment
  int mono_max_extrapolated_frames = 30; // lost frames' poses follow constant velocity this long, then stay
};

}  // namespace chungs::tracking
