// The sparse map the tracker keeps: keyframes (pose + features) and 3D points with their observations.
#pragma once
#include <Eigen/Core>
#include <map>
#include <opencv2/core.hpp>
#include <unordered_map>
#include <vector>

#include "chungs/geometry/se3.hpp"
#include "chungs/tracking/features.hpp"

namespace chungs::tracking {

struct MapPoint {
  long id = -1;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();  // world
  cv::Mat desc;                                  // 1 x 32, from the latest keyframe observation
  std::map<long, int> obs;                       // keyframe id -> keypoint index in that keyframe
  long first_kf = -1;
  int visible = 0, found = 0;  // times predicted inside a frame / times matched there
};

struct Keyframe {
  long id = -1;
  size_t frame_index = 0;
  double stamp = 0;
  SE3 T_wc;                 // camera-to-world
  Features feat;
  std::vector<long> points; // per keypoint: map point id or -1
  bool bad = false;         // culled: pose follows `parent` through T_parent_this
  long parent = -1;
  SE3 T_parent_this;
  SE3 T_cw() const { return T_wc.inverse(); }
};

class Map {
 public:
  Keyframe& add_keyframe(Keyframe kf);  // assigns the id
  long add_point(const Eigen::Vector3d& pos, long kf, int kp);
  void add_observation(long point, long kf, int kp);
  void erase_observation(long point, long kf);  // erases the point when it has no observation left
  void erase_point(long point);

  Keyframe& kf(long id) { return kfs_.at(size_t(id)); }
  const Keyframe& kf(long id) const { return kfs_.at(size_t(id)); }
  size_t keyframes() const { return kfs_.size(); }
  MapPoint* point(long id);
  const MapPoint* point(long id) const;
  size_t points() const { return points_.size(); }
  const std::unordered_map<long, MapPoint>& all_points() const { return points_; }

  // Pose of a keyframe, following the parent chain of culled ones.
  SE3 pose(long kf_id) const;
  // Keyframes sharing at least `min_shared` points with `kf_id`, most shared first, at most `max` of them.
  std::vector<std::pair<long, int>> covisible(long kf_id, int min_shared = 15, size_t max = 1000) const;
  // Removes a redundant keyframe: observations go, its pose is kept relative to `parent`.
  void cull_keyframe(long kf_id, long parent);

 private:
  std::vector<Keyframe> kfs_;
  std::unordered_map<long, MapPoint> points_;
  long next_point_ = 0;
};

}  // namespace chungs::tracking
