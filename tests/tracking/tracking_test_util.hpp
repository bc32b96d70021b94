// Helpers for tracker tests: run a tracker over a dataset and measure ATE with a rigid alignment.
#pragma once
#include <cmath>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/geometry/umeyama.hpp"
#include "chungs/tracking/visual_tracker.hpp"

namespace chungs::test {

struct RunStats {
  Trajectory est, gt;
  size_t lost = 0, keyframes = 0;
  std::vector<tracking::MapOperation> ops;
};

inline RunStats run_tracker(const Dataset& ds, tracking::Tracker& tracker, size_t max_frames = 100000) {
  RunStats s;
  for (size_t i = 0; i < std::min(ds.size(), max_frames); ++i) {
    Frame f = ds.frame(i);
    auto r = tracker.track(f);
    s.lost += r.state == tracking::TrackState::Lost;
    s.keyframes += r.keyframe;
    if (f.gt_pose) s.gt.push_back(f.timestamp, *f.gt_pose);
    for (auto& op : tracker.take_map_operations()) s.ops.push_back(std::move(op));
  }
  s.est = tracker.trajectory();
  return s;
}

// RMSE of positions after the best rigid alignment; both trajectories hold the same frames in order.
inline double ate_rmse(const Trajectory& gt, const Trajectory& est) {
  std::vector<Eigen::Vector3d> a, b;
  for (size_t i = 0; i < std::min(gt.size(), est.size()); ++i) a.push_back(est.poses[i].t), b.push_back(gt.poses[i].t);
  Sim3 S = umeyama_align(a, b, false);
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += (S * a[i] - b[i]).squaredNorm();
  return std::sqrt(sum / double(a.size()));
}

}  // namespace chungs::test
