// FrameFeed: where the mapper's frames, poses and keyframe decisions come from, one item per
// frame in order. Given poses (ground truth or a trajectory file) with the mapper's own keyframe
// rule, or the visual tracker, running on its own thread, with its keyframes and the pose
// corrections of bundle adjustment and loop closure.
#pragma once
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/mapping/mapper_config.hpp"

namespace chungs {

// Keyframe poses that the source changed, by the source's keyframe ids.
struct PoseUpdate {
  bool loop = false;                          // a loop closure (else bundle adjustment)
  long query = -1, match = -1;                // loop: the keyframes that recognised each other
  std::vector<std::pair<long, SE3>> poses;    // keyframe id -> new camera-to-world pose
  std::vector<long> junction;                 // loop: keyframes next to the loop edge
};

struct FeedItem {
  size_t frame = 0;
  std::optional<SE3> pose;          // none: the frame has no pose and is skipped
  bool keyframe = false;            // the mapper adds it (never for a held-out frame)
  long keyframe_id = -1;            // the source's id for it (the frame index for given poses)
  std::vector<PoseUpdate> updates;  // to apply after this frame
  // The tracker's sparse map (issue 25): the points this keyframe observes (world), the prior of its
  // depth from one camera; of them, those no earlier keyframe handed over, which become Gaussians of
  // this keyframe (sampler.map_point_seeds); and keyframes the tracker made that the map does not take
  // (a monocular segment's first view), as neighbours for the plane sweep.
  std::vector<Eigen::Vector3d> map_points, seeds;
  struct View {
    size_t frame = 0;
    long id = -1;  // the source's keyframe id (its pose updates name it)
    SE3 pose;
  };
  std::vector<View> sweep_views;
};

class FrameFeed {
 public:
  virtual ~FrameFeed() = default;
  virtual std::optional<FeedItem> next() = 0;  // none after the last frame
  // Whether next() would return without waiting (a live source such as the tracker may make it wait).
  virtual bool ready() const { return true; }
  // The median depth (m) of a keyframe just loaded: the scale that keyframe_parallax refers to.
  virtual void set_scene_depth(double /*median_m*/) {}
  // Every frame's final pose (after all corrections), for evaluation; call after the last item.
  virtual std::vector<std::optional<SE3>> final_poses() = 0;
  virtual nlohmann::json report() const = 0;  // about the source (tracking: ATE, timings)
  // Why the source gave no frame a pose (the tracker never started), or ""; call after the last item.
  virtual std::string why_no_pose() { return {}; }
};

// Frames [start, n) with the given poses; keyframes by MapperConfig's keyframe rules,
// counted from `last_keyframe` (the pose of the map's latest keyframe when resuming).
std::unique_ptr<FrameFeed> make_given_pose_feed(std::vector<std::optional<SE3>> poses, size_t start, size_t n,
                                                const MapperConfig& config, std::optional<SE3> last_keyframe);

}  // namespace chungs
