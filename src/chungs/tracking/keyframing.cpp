// Keyframe decisions and insertion (new points from depth, local bundle adjustment, culling of points and
// redundant keyframes), and what the tracker hands out: map operations and the trajectory.
#include <algorithm>
#include <chrono>

#include "chungs/common/log.hpp"
#include "chungs/common/stopwatch.hpp"
#include "chungs/tracking/local_ba.hpp"
#include "chungs/tracking/visual_tracker.hpp"

namespace chungs::tracking {

bool VisualTracker::need_keyframe(const Current& c, int inliers) const {
  if (mono_) return need_keyframe_mono(c, inliers);
  // The reference keyframe's points that other keyframes confirmed: fresh single-view points (most of
  // a new keyframe's) would make every following frame look like it lost track of the reference.
  const int min_obs = map_.keyframes() <= 2 ? 2 : 3;
  int ref_points = 0, ref_all = 0;
  for (long pid : map_.kf(ref_kf_).points)
    if (const MapPoint* p = pid >= 0 ? map_.point(pid) : nullptr) {
      ref_points += int(p->obs.size()) >= min_obs;
      ++ref_all;
    }
  // Close points (reliable depth) the frame tracks, and close features it could add.
  int tracked_close = 0, untracked_close = 0;
  const double close = close_depth();
  for (size_t i = 0; i < c.f.size(); ++i) {
    if (!c.f.has_depth(i) || c.f.depth[i] > close) continue;
    (c.matches[i] >= 0 ? tracked_close : untracked_close)++;
  }
  const bool need_close = tracked_close < 100 && untracked_close > 70;
  const size_t since = c.index - last_kf_frame_;
  if (opt_.max_keyframe_interval > 0 && since >= size_t(opt_.max_keyframe_interval)) return true;
  // Right after a keyframe only a weak frame (few points left, or a view with many new close features)
  // makes another one.
  const bool weak = inliers < 0.25 * ref_points || need_close;
  if (since < size_t(opt_.min_keyframe_interval) && !weak) return false;
  // Also when the frame keeps less than a share of all the reference's points: on fast turns the
  // confirmed points alone lag behind and tracking would run out of points before they trigger.
  return inliers < opt_.keyframe_ratio * ref_points || inliers < opt_.keyframe_all_ratio * ref_all || need_close;
}

long VisualTracker::create_keyframe(Current& c) {
  Keyframe kf;
  kf.frame_index = c.index;
  kf.stamp = c.stamp;
  kf.T_wc = c.T_cw.inverse();
  kf.feat = c.f;
  const long id = map_.add_keyframe(std::move(kf)).id;
  for (size_t i = 0; i < c.matches.size(); ++i)
    if (c.matches[i] >= 0 && map_.point(c.matches[i])) map_.add_observation(c.matches[i], id, int(i));
  // New points from features with depth, nearest first: all close ones, and far ones until there are 100.
  std::vector<std::pair<float, int>> cand;
  for (size_t i = 0; i < c.f.size(); ++i)
    if (c.matches[i] < 0 && c.f.has_depth(i) && !c.is_moving(i)) cand.emplace_back(c.f.depth[i], int(i));
  std::sort(cand.begin(), cand.end());
  const SE3 T_wc = map_.kf(id).T_wc;
  const double close = close_depth();
  // A single camera has no depth: new points come from this keyframe's matches with its neighbours.
  int created = mono_ ? triangulate_new_points(id) : 0;
  for (auto& [z, i] : cand) {
    if (z > close && created >= 100) break;
    const auto& kp = c.f.kps[i];
    Eigen::Vector3d pc((kp.pt.x - k_.cx) / k_.fx * z, (kp.pt.y - k_.cy) / k_.fy * z, z);
    long pid = map_.add_point(T_wc * pc, id, i);
    c.matches[i] = pid;
    recent_points_.push_back(pid);
    ++created;
  }
  ref_kf_ = id;
  last_kf_frame_ = c.index;
  ++timings_.keyframes;

  MapOperation added;
  std::vector<std::pair<long, SE3>> moved;
  if (opt_.local_ba && map_.keyframes() > 1) {
    // Culled keyframes move with their parents: the mapper hears about those too.
    std::vector<std::pair<long, SE3>> culled;
    for (long k = 0; k < long(map_.keyframes()); ++k)
      if (map_.kf(k).bad) culled.emplace_back(k, map_.pose(k));
    const auto tb = std::chrono::steady_clock::now();
    LocalBAResult ba = local_bundle_adjust(map_, id, k_, opt_.orb.scale_factor, mono_ ? opt_.mono_ba_window : opt_.ba_window,
                                           opt_.ba_iterations);
    timings_.ba_ms += ms_since(tb);
    for (long k : ba.keyframes)
      if (k != id) moved.emplace_back(k, map_.pose(k));
    for (auto& [k, old] : culled) {
      const SE3 now = map_.pose(k);
      if (now.t != old.t || now.q.coeffs() != old.q.coeffs()) moved.emplace_back(k, now);
    }
    c.T_cw = map_.kf(id).T_cw();
    last_T_cw_ = c.T_cw;
  }
  cull_points(id);
  if (opt_.cull_keyframes) cull_keyframes(id);
  std::optional<LoopEvent> loop;
  if (opt_.loop_closure) {
    if (!loops_) {
      LoopOptions lo = opt_.loop;
      lo.scale_factor = opt_.orb.scale_factor;
      lo.similarity = mono_;
      loops_ = std::make_unique<LoopCloser>(lo, k_, width_, height_);
    }
    const auto tl = std::chrono::steady_clock::now();
    loop = loops_->process(map_, id);
    timings_.loop_ms += ms_since(tl);
    if (loop) {
      ++timings_.loops;
      c.T_cw = map_.kf(id).T_cw();
      last_T_cw_ = c.T_cw;
    }
  }
  last_points_.clear();
  for (long pid : map_.kf(id).points)
    if (pid >= 0) last_points_.push_back(pid);
  for (size_t i = 0; i < c.matches.size(); ++i) c.matches[i] = map_.kf(id).points[i];

  added.kind = MapOperation::Kind::NewKeyframe;
  added.keyframe = record(id);
  ops_.push_back(std::move(added));
  if (!moved.empty()) {
    MapOperation upd;
    upd.kind = MapOperation::Kind::PosesUpdated;
    upd.poses = std::move(moved);
    ops_.push_back(std::move(upd));
  }
  if (loop) {
    MapOperation op;
    op.kind = MapOperation::Kind::LoopClosure;
    op.loop = std::move(*loop);
    ops_.push_back(std::move(op));
  }
  log::debug("tracking: keyframe ", id, " at frame ", c.index, ", ", created, " new points, map ", map_.points());
  return id;
}

void VisualTracker::cull_points(long kf) {
  std::vector<long> keep;
  for (long pid : recent_points_) {
    MapPoint* p = map_.point(pid);
    if (!p) continue;
    const long age = kf - p->first_kf;
    // Seen where predicted too rarely, or not confirmed by another keyframe soon after its creation.
    if (p->visible >= 4 && p->found < 0.25 * p->visible) {
      map_.erase_point(pid);
      continue;
    }
    // A monocular point is born seen twice: it must be confirmed by a third keyframe.
    if (age >= 2 && p->obs.size() < (mono_ ? 3u : 2u)) {
      map_.erase_point(pid);
      continue;
    }
    if (age < 3) keep.push_back(pid);
  }
  recent_points_ = std::move(keep);
}

void VisualTracker::cull_keyframes(long kf) {
  // A keyframe is redundant when 90 % of its close points are seen by at least three other keyframes.
  const double close = close_depth();
  for (auto& [id, shared] : map_.covisible(kf, 15, 20)) {
    if (id == 0 || id == kf || map_.kf(id).bad || id >= kf - 1) continue;
    const Keyframe& K = map_.kf(id);
    int total = 0, redundant = 0;
    for (size_t i = 0; i < K.points.size(); ++i) {
      const MapPoint* p = K.points[i] >= 0 ? map_.point(K.points[i]) : nullptr;
      if (!p || (!mono_ && (!K.feat.has_depth(i) || K.feat.depth[i] > close))) continue;
      ++total;
      redundant += p->obs.size() >= 4;
    }
    if (total == 0 || redundant < 0.9 * total) continue;
    auto cov = map_.covisible(id, 15, 1);
    if (cov.empty()) continue;
    map_.cull_keyframe(id, cov.front().first);
    log::debug("tracking: culled redundant keyframe ", id, " (parent ", cov.front().first, ")");
  }
}

KeyframeRecord VisualTracker::record(long id) const {
  const Keyframe& K = map_.kf(id);
  KeyframeRecord r;
  r.id = id;
  r.frame_index = K.frame_index;
  r.stamp = K.stamp;
  r.pose = map_.pose(id);
  for (size_t i = 0; i < K.points.size(); ++i) {
    const MapPoint* p = K.points[i] >= 0 ? map_.point(K.points[i]) : nullptr;
    if (!p) continue;
    r.point_ids.push_back(p->id);
    r.points.push_back(p->pos);
    r.pixels.emplace_back(K.feat.kps[i].pt.x, K.feat.kps[i].pt.y);
  }
  return r;
}

std::vector<MapOperation> VisualTracker::take_map_operations() {
  std::vector<MapOperation> out;
  out.swap(ops_);
  return out;
}

Trajectory VisualTracker::trajectory() const {
  Trajectory t;
  // A monocular frame before the first map segment has no pose (ref_kf -1).
  for (const auto& f : frames_)
    if (f.ref_kf >= 0) t.push_back(f.stamp, map_.pose(f.ref_kf) * f.T_ref_c);
  return t;
}

}  // namespace chungs::tracking
