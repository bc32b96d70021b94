// The Tracker interface: consumes Frames, produces per-frame poses, keyframe decisions, each keyframe's sparse
// 3D points with their observations, and map operations for the mapper (new keyframes, poses changed by
// bundle adjustment, loop closures).
#pragma once
#include <Eigen/Core>
#include <cstdint>
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
  uint32_t doubts = 0;                     // TrackDoubt bits of the frame it was made from (0: confident)
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

// Why a tracked pose is doubtful (issue 23), one bit each; 0 is a confident estimate.
enum TrackDoubt : uint32_t {
  kDoubtFewInliers = 1,    // the pose rests on few map points
  kDoubtDisagree = 2,      // the map-based pose and the frame-to-frame motion (or the prediction) disagree
  kDoubtImplausible = 4,   // a jump: faster or turning faster than the tracker's limits
  kDoubtCoasting = 8,      // the static world could not be measured; the pose is the prediction
  kDoubtAmbiguous = 16,    // another motion (a moving object) had about as much support as the one taken
};
// "few_inliers+disagree", or "" for 0.
std::string doubt_names(uint32_t doubts);

struct TrackResult {
  size_t frame_index = 0;
  double stamp = 0;
  SE3 pose;                    // camera-to-world (last good pose while lost)
  TrackState state = TrackState::Ok;
  bool keyframe = false;
  long keyframe_id = -1;       // the new keyframe, or the reference keyframe
  int inliers = 0;             // map points the pose rests on
  uint32_t doubts = 0;         // TrackDoubt bits: the estimate may be wrong (a lost frame has none)
  bool doubtful() const { return doubts != 0; }
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
