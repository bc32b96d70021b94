// The Tracker interface: consumes Frames, produces per-frame poses, keyframe decisions, each keyframe's sparse
// 3D points with their observations, and map operations for the mapper (new keyframes, poses changed by
// bundle adjustment, loop closures).
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "chungs/datasets/frame.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/geometry/trajectory.hpp"

namespace chungs::tracking {

enum class TrackState { Ok, Recovered, Lost };
const char* state_name(TrackState s);

// One keyframe as the mapper sees it: its pose and the sparse points it observes.
struct KeyframeRecord {
  long id = -1;
  size_t frame_index = 0;
  double stamp = 0;
  SE3 pose;                                // camera-to-world
  std::vector<long> point_ids;             // one per observed point
  std::vector<Eigen::Vector3d> points;     // world positions, same order
  std::vector<Eigen::Vector2f> pixels;     // where this keyframe observes them
};

// A loop closure: keyframe `query` recognised the place of keyframe `match`; every listed keyframe moved from
// its old pose to its new one. `junction` holds the keyframes next to the loop edge on both sides, where the
// mapper should reset and refine.
struct LoopEvent {
  long query = -1, match = -1;
  std::vector<long> junction;
  std::vector<std::pair<long, SE3>> old_poses, new_poses;
};

struct MapOperation {
  enum class Kind { NewKeyframe, PosesUpdated, LoopClosure } kind = Kind::NewKeyframe;
  KeyframeRecord keyframe;                      // NewKeyframe
  std::vector<std::pair<long, SE3>> poses;      // PosesUpdated: keyframe id -> new pose
  LoopEvent loop;                               // LoopClosure
};

struct TrackResult {
  size_t frame_index = 0;
  double stamp = 0;
  SE3 pose;                    // camera-to-world (last good pose while lost)
  TrackState state = TrackState::Ok;
  bool keyframe = false;
  long keyframe_id = -1;       // the new keyframe, or the reference keyframe
  int inliers = 0;             // map points the pose rests on
};

class Tracker {
 public:
  virtual ~Tracker() = default;
  // Throws Error naming the frame when it cannot be used (no depth source, wrong size).
  virtual TrackResult track(const Frame& frame) = 0;
  // Operations produced since the last call, oldest first.
  virtual std::vector<MapOperation> take_map_operations() = 0;
  // Every tracked frame's latest pose estimate (frames are stored relative to a keyframe, so bundle
  // adjustment and loop closure corrections reach them).
  virtual Trajectory trajectory() const = 0;
  virtual std::string describe() const = 0;
};

}  // namespace chungs::tracking
