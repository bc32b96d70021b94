// Feature-based visual SLAM tracker for rectified stereo, RGB-D and monocular frames: ORB features (with
// depth where the input gives it), constant-velocity tracking against the local map with a PnP-RANSAC
// fallback, keyframes with local bundle adjustment and culling, relocalisation after loss, and loop closure
// with an SE3 pose graph. Monocular input (issue 25, mono_tracking.cpp) starts each map segment from two
// views, triangulates new points between keyframes, and after a loss it cannot relocalise from starts a
// new segment.
#pragma once
#include <memory>
#include <optional>

#include "chungs/tracking/frame_motion.hpp"
#include "chungs/tracking/loop_closer.hpp"
#include "chungs/tracking/map.hpp"
#include "chungs/tracking/options.hpp"
#include "chungs/tracking/tracker.hpp"

namespace chungs::tracking {

struct TrackerTimings {
  double features_ms = 0, tracking_ms = 0, keyframe_ms = 0;  // totals
  double ba_ms = 0, loop_ms = 0;  // parts of keyframe_ms: local bundle adjustment, loop detection and closing
  double ahead_ms = 0;  // features prepared on another thread (not part of the tracker thread's time)
  size_t frames = 0, keyframes = 0, loops = 0, lost_frames = 0;
  size_t doubtful_frames = 0, coasted_frames = 0;
  size_t map_segments = 0, reinitialisations = 0;  // monocular: segments started, and those after a loss
  int most_points_before_start = 0;  // with depth: the most features with depth of a frame that could not start
};

// A frame's features (ORB on both images and their stereo matches, or depth attached), computed
// without the tracker's state.
struct PreparedFrame {
  size_t index = 0;  // the frame's
  Features f;
  cv::Mat gray;
  double ms = 0;  // time it took
};

class VisualTracker : public Tracker {
 public:
  explicit VisualTracker(TrackerOptions opt = {});
  ~VisualTracker() override;
  TrackResult track(const Frame& frame) override;
  // The features of a frame, with the same options as the tracker's: touches no tracker state, so a
  // reader thread may prepare the next frame while track() works on this one (half of a stereo
  // frame's tracking time at KITTI's full resolution is its features).
  static std::shared_ptr<PreparedFrame> prepare(const Frame& frame, const TrackerOptions& opt);
  // track(frame) with its features prepared ahead (null: computed here).
  TrackResult track(const Frame& frame, std::shared_ptr<PreparedFrame> prepared);
  const TrackerOptions& options() const { return opt_; }
  std::vector<MapOperation> take_map_operations() override;
  Trajectory trajectory() const override;
  std::string describe() const override;
  // Why no frame has a pose yet ("" once the tracker has started): the frames it saw and, with depth,
  // the most features with depth any of them had against the number starting needs.
  std::string why_not_started() const;
  const Map& map() const { return map_; }
  const TrackerTimings& timings() const { return timings_; }

 private:
  struct Current {
    size_t index = 0;
    double stamp = 0;
    Features f;
    SE3 T_cw;
    std::vector<long> matches;  // per keypoint: map point id or -1
    cv::Mat gray;
    std::vector<char> moving;   // per keypoint: on an independently moving object (empty: none known)
    bool is_moving(size_t i) const { return !moving.empty() && moving[i]; }
  };

  void extract(const Frame& frame, Current& c, std::shared_ptr<PreparedFrame> prepared);
  bool initialize(Current& c);
  int optimize(Current& c);  // pose-only on current matches; drops outliers; returns inliers
  int track_motion(Current& c, const SE3& predicted);  // inliers of the predicted pose after refinement
  bool track_pnp(Current& c, const std::vector<long>& keyframes);
  int track_local_map(Current& c);
  std::vector<long> local_keyframes(const Current& c) const;
  std::vector<long> keyframes_seeing(const std::vector<long>& points) const;  // most shared first
  bool need_keyframe(const Current& c, int inliers) const;
  // The end of a tracked frame, stereo or monocular: the keyframe when allowed and needed, the pose, the
  // frame's record.
  TrackResult finish_tracked(Current& c, TrackResult res, bool recovered, int inliers, uint32_t doubts,
                             bool may_make_keyframe);
  long create_keyframe(Current& c);
  void cull_points(long kf);
  void cull_keyframes(long kf);
  KeyframeRecord record(long kf) const;
  double close_depth() const;
  // Monocular (mono_tracking.cpp, mono_mapping.cpp).
  TrackResult track_mono(Current& c, TrackResult res);
  bool start_segment(Current& c, TrackResult& res);  // two-view initialisation against init_ref_
  bool need_keyframe_mono(const Current& c, int inliers) const;
  int triangulate_new_points(long kf);   // also fuses the keyframe's points with its neighbours'
  void fuse_with_neighbours(long kf);
  void loop_check_keyframe(long kf, Current& c);

  TrackerOptions opt_;
  Map map_;
  std::unique_ptr<LoopCloser> loops_;
  std::vector<MapOperation> ops_;
  struct FrameRecord {
    double stamp;
    long ref_kf;
    SE3 T_ref_c;
  };
  std::vector<FrameRecord> frames_;
  Intrinsics k_{};
  int width_ = 0, height_ = 0;
  bool stereo_ = false;
  double baseline_ = 0;
  SE3 last_T_cw_;
  std::optional<SE3> velocity_;  // T_cw(now) * T_cw(previous)^-1
  std::vector<long> last_points_;
  long ref_kf_ = -1;
  size_t last_kf_frame_ = 0;
  bool lost_ = false;
  int last_inliers_ = 0;  // local-map inliers of the last tracked frame
  std::vector<long> recent_points_;
  TrackerTimings timings_;
  // The last tracked frame's features, for the frame-to-frame motion (issue 23).
  Features prev_f_;
  bool prev_valid_ = false;
  double prev_stamp_ = 0;
  int coast_frames_ = 0;  // frames in a row whose pose is the prediction
  // Monocular state.
  bool mono_ = false;
  struct InitReference {
    size_t index = 0;
    double stamp = 0;
    Features f;
    size_t frame_record = 0;  // its entry in frames_
    SE3 T_wc_guess;           // where the last segment's motion puts it
  };
  std::optional<InitReference> init_ref_;
  SE3 lost_T_cw_;           // while lost: the pose constant velocity extrapolates to
  int lost_frames_in_row_ = 0;
  double next_segment_depth_ = 0;  // median scene depth (world units) the next segment is scaled to
  long segment_first_kf_ = 0;      // the current segment's first keyframe
  double next_segment_speed_ = 0;  // map units per frame the camera moved before the loss (0: unknown)
};

}  // namespace chungs::tracking
