// Monocular tracking (issue 25): map segments started from two views, tracking against the local map with
// the stereo tracker's machinery (motion model, PnP fallback, local map, keyframes, local BA, loop closure),
// and after a loss first relocalisation in the existing map, then a new segment.
//
// Scale: the first segment's unit is the median scene depth of its first keyframe (= 1). A later segment
// cannot be measured against the earlier ones. It is scaled so that the camera keeps the speed (map units per
// frame) it had before the loss, since a camera on a vehicle or in a hand does not change speed in a few
// frames while the scene depth does (a turn from a narrow street into a square); without a speed, to the
// median depth the last keyframe before the loss had. It is placed where constant velocity from the last
// tracked pose puts its first frame. Both are the closest guess to continuity, not a measurement (`track`
// says how many segments there were).
#include <algorithm>
#include <chrono>
#include <cmath>

#include "chungs/common/log.hpp"
#include "chungs/common/stopwatch.hpp"
#include "chungs/tracking/local_ba.hpp"
#include "chungs/tracking/visual_tracker.hpp"

namespace chungs::tracking {
namespace {

// The motion T^a (a in [0, 1]): the rotation's angle and the translation scaled alike.
SE3 scaled_motion(const SE3& T, double a) {
  const Eigen::AngleAxisd aa(T.q);
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(aa.angle() * a, aa.axis())), T.t * a);
}

double median_depth(const Map& map, long kf) {
  const Keyframe& K = map.kf(kf);
  const SE3 T = map.pose(kf).inverse();
  std::vector<double> z;
  for (long pid : K.points)
    if (const MapPoint* p = pid >= 0 ? map.point(pid) : nullptr) z.push_back((T * p->pos).z());
  if (z.empty()) return 0;
  std::nth_element(z.begin(), z.begin() + long(z.size() / 2), z.end());
  return z[z.size() / 2];
}

}  // namespace

void VisualTracker::loop_check_keyframe(long kf, Current& c) {
  if (!opt_.loop_closure) return;
  if (!loops_) {
    LoopOptions lo = opt_.loop;
    lo.scale_factor = opt_.orb.scale_factor;
    lo.similarity = true;
    loops_ = std::make_unique<LoopCloser>(lo, k_, width_, height_);
  }
  const auto tl = std::chrono::steady_clock::now();
  auto loop = loops_->process(map_, kf);
  timings_.loop_ms += ms_since(tl);
  if (!loop) return;
  ++timings_.loops;
  c.T_cw = map_.kf(kf).T_cw();
  last_T_cw_ = c.T_cw;
  MapOperation op;
  op.kind = MapOperation::Kind::LoopClosure;
  op.loop = std::move(*loop);
  ops_.push_back(std::move(op));
}

bool VisualTracker::start_segment(Current& c, TrackResult& res) {
  const int need = opt_.mono_init.min_matches;
  auto take_as_reference = [&] {
    if (int(c.f.size()) < need) return;  // a blank or featureless frame cannot start anything
    InitReference r;
    r.index = c.index;
    r.stamp = c.stamp;
    r.f = c.f;
    r.frame_record = frames_.size();
    r.T_wc_guess = (timings_.map_segments == 0 ? SE3() : lost_T_cw_).inverse();
    init_ref_ = std::move(r);
  };
  if (!init_ref_) {
    take_as_reference();
    return false;
  }
  TwoViewOptions to = opt_.mono_init;
  to.scale_factor = opt_.orb.scale_factor;
  if (timings_.map_segments > 0 && next_segment_depth_ > 0) to.target_median_depth = next_segment_depth_;
  std::vector<std::pair<int, int>> pairs;
  TwoViewResult r = initialize_two_view(init_ref_->f, c.f, k_, width_, height_, pairs, to);
  if (r.ok && timings_.map_segments > 0 && next_segment_speed_ > 0) {
    const double f = next_segment_speed_ * double(c.index - init_ref_->index) / r.T_21.t.norm();
    for (auto& P : r.points) P *= f;
    r.T_21.t *= f;
    to.target_median_depth *= f;
  }
  if (!r.ok) {
    log::debug("tracking: frame ", c.index, " against frame ", init_ref_->index, ": no initialisation (", r.why, ")");
    // Too few matches left (the view moved on) or too long a wait: start again from this frame.
    if (r.matches < need || c.index - init_ref_->index > size_t(opt_.mono_init_max_frames)) take_as_reference();
    return false;
  }
  // Two keyframes and the points they share.
  Keyframe k0, k1;
  k0.frame_index = init_ref_->index;
  k0.stamp = init_ref_->stamp;
  k0.T_wc = init_ref_->T_wc_guess;
  k0.feat = init_ref_->f;
  k1.frame_index = c.index;
  k1.stamp = c.stamp;
  k1.T_wc = k0.T_wc * r.T_21.inverse();
  k1.feat = c.f;
  const long id0 = map_.add_keyframe(std::move(k0)).id;
  const long id1 = map_.add_keyframe(std::move(k1)).id;
  segment_first_kf_ = id0;
  const SE3 T_w0 = map_.kf(id0).T_wc;
  for (size_t j = 0; j < r.used.size(); ++j) {
    auto [a, b] = pairs[size_t(r.used[j])];
    const long pid = map_.add_point(T_w0 * r.points[j], id0, a);
    map_.add_observation(pid, id1, b);
  }
  ++timings_.map_segments;
  timings_.keyframes += 2;
  const bool again = timings_.map_segments > 1;
  if (again) ++timings_.reinitialisations;
  log::info("tracking: ", again ? "new map segment" : "map initialised", " from frames ", init_ref_->index, " and ",
            c.index, " (", model_name(r.model), ", ", r.used.size(), " points, median parallax ", r.median_parallax_deg,
            " deg; scale: median depth of the first keyframe = ", to.target_median_depth, ")");
  // The frames since the reference were reported lost; they now lie between the two keyframes.
  const SE3 T_01 = r.T_21.inverse();
  const double span = c.stamp - init_ref_->stamp;
  for (size_t k = init_ref_->frame_record; k < frames_.size(); ++k) {
    const double a = span > 0 ? std::clamp((frames_[k].stamp - init_ref_->stamp) / span, 0.0, 1.0) : 0.0;
    frames_[k] = {frames_[k].stamp, id0, scaled_motion(T_01, a)};
  }
  const size_t steps = std::max<size_t>(1, c.index - init_ref_->index);
  init_ref_.reset();
  c.T_cw = map_.kf(id1).T_cw();
  last_T_cw_ = c.T_cw;
  velocity_ = scaled_motion(r.T_21, 1.0 / double(steps));
  ref_kf_ = id1;
  last_kf_frame_ = c.index;
  lost_ = false;
  lost_frames_in_row_ = 0;
  last_points_.clear();
  const auto& kf1_points = map_.kf(id1).points;
  for (size_t i = 0; i < kf1_points.size(); ++i)
    if (kf1_points[i] >= 0) last_points_.push_back(kf1_points[i]), c.matches[i] = kf1_points[i];
  last_inliers_ = int(last_points_.size());
  prev_stamp_ = c.stamp;
  for (long id : {id0, id1}) {
    MapOperation op;
    op.kind = MapOperation::Kind::NewKeyframe;
    op.keyframe = record(id);
    ops_.push_back(std::move(op));
    loop_check_keyframe(id, c);
  }
  res.state = again ? TrackState::Recovered : TrackState::Ok;
  res.keyframe = true;
  res.keyframe_id = id1;
  res.inliers = last_inliers_;
  res.pose = c.T_cw.inverse();
  frames_.push_back({c.stamp, id1, SE3()});
  return true;
}

bool VisualTracker::need_keyframe_mono(const Current& c, int inliers) const {
  // The reference keyframe's points that a third keyframe confirmed (two while the map is young): a new point
  // is seen by two keyframes from birth, so counting those would make every frame look like a lost view.
  const size_t min_obs = map_.keyframes() - size_t(segment_first_kf_) <= 2 ? 2 : 3;
  int ref_points = 0;
  for (long pid : map_.kf(ref_kf_).points)
    if (const MapPoint* p = pid >= 0 ? map_.point(pid) : nullptr) ref_points += p->obs.size() >= min_obs;
  const size_t since = c.index - last_kf_frame_;
  if (since < 1) return false;
  if (opt_.mono_max_keyframe_interval > 0 && since >= size_t(opt_.mono_max_keyframe_interval)) return true;
  // A minimum spacing (mono_min_keyframe_interval, 1 by default) keeps keyframes apart; a frame that tracks
  // few points makes one anyway. Spaced 3 frames apart, the keyframes came too late at the street's tight
  // corners: the map ran out of points and tracking was lost (bench/README.md, "Monocular tracking").
  const bool weak = inliers < 3 * opt_.mono_min_inliers;
  if (weak) return true;
  if (since < size_t(opt_.mono_min_keyframe_interval)) return false;
  // Without depth only keyframes make new points, so they come sooner than with stereo: as soon as the frame
  // keeps clearly fewer than the reference's points.
  return inliers < opt_.mono_keyframe_ratio * ref_points;
}

TrackResult VisualTracker::track_mono(Current& c, TrackResult res) {
  const auto t1 = std::chrono::steady_clock::now();
  auto lost_result = [&] {
    ++timings_.lost_frames;
    res.state = TrackState::Lost;
    res.keyframe_id = ref_kf_;
    if (map_.keyframes() == 0) {
      res.pose = SE3();
      frames_.push_back({c.stamp, -1, SE3()});
    } else {
      res.pose = lost_T_cw_.inverse();
      frames_.push_back({c.stamp, ref_kf_, map_.pose(ref_kf_).inverse() * res.pose});
    }
    timings_.tracking_ms += ms_since(t1);
    return res;
  };
  if (map_.keyframes() == 0) {
    if (start_segment(c, res)) {
      timings_.tracking_ms += ms_since(t1);
      return res;
    }
    return lost_result();
  }

  bool ok = false, recovered = false;
  int inliers = 0;
  if (!lost_) {
    const SE3 predicted = velocity_ ? *velocity_ * last_T_cw_ : last_T_cw_;
    const int motion = track_motion(c, predicted);
    log::debug("tracking: frame ", c.index, " motion model: ", motion, " inliers (last frame ", last_inliers_, ")");
    ok = motion >= opt_.mono_min_inliers;
    if (!ok || motion < opt_.motion_check_ratio * last_inliers_) {
      // A sudden turn: descriptor matches against the local map's keyframes, kept if they explain more.
      Current alt;
      alt.index = c.index;
      alt.f = c.f;
      alt.T_cw = last_T_cw_;
      alt.matches.assign(c.f.size(), -1);
      auto kfs = keyframes_seeing(last_points_);
      if (kfs.empty()) kfs.push_back(ref_kf_);
      if (track_pnp(alt, kfs)) {
        const int n = int(std::count_if(alt.matches.begin(), alt.matches.end(), [](long m) { return m >= 0; }));
        if (!ok || n > motion) {
          c.T_cw = alt.T_cw;
          c.matches = std::move(alt.matches);
          ok = true;
        }
      }
    }
  } else if (opt_.mono_relocalise) {
    std::vector<long> kfs;
    for (long i = long(map_.keyframes()) - 1; i >= 0; --i)
      if (!map_.kf(i).bad) kfs.push_back(i);
    ok = recovered = track_pnp(c, kfs);
  }
  const int first = ok ? int(std::count_if(c.matches.begin(), c.matches.end(), [](long m) { return m >= 0; })) : 0;
  if (ok) inliers = track_local_map(c);
  log::debug("tracking: frame ", c.index, ": ", first, " inliers from the first pose, ", inliers, " after the local map");
  ok = ok && inliers >= opt_.mono_min_inliers;
  if (!ok) {
    if (!lost_) {
      log::warn("tracking: lost at frame ", c.index, " (", inliers, " inliers); relocalising or starting a new map segment");
      lost_ = true;
      lost_T_cw_ = last_T_cw_;
      lost_frames_in_row_ = 0;
      next_segment_depth_ = median_depth(map_, ref_kf_);
      next_segment_speed_ = velocity_ ? velocity_->t.norm() : 0;
      init_ref_.reset();
      last_inliers_ = 0;
    }
    // The frame's pose while lost: constant velocity from the last tracked one, for a while.
    if (velocity_ && lost_frames_in_row_++ < opt_.mono_max_extrapolated_frames) lost_T_cw_ = *velocity_ * lost_T_cw_;
    if (start_segment(c, res)) {
      timings_.tracking_ms += ms_since(t1);
      return res;
    }
    return lost_result();
  }
  if (lost_) log::info("tracking: relocalised at frame ", c.index, " with ", inliers, " inliers");
  lost_ = false;
  init_ref_.reset();
  uint32_t doubts = inliers < opt_.confident_inliers ? kDoubtFewInliers : 0;
  if (doubts) ++timings_.doubtful_frames;
  if (!recovered) velocity_ = c.T_cw * last_T_cw_.inverse();
  else velocity_.reset();
  last_T_cw_ = c.T_cw;
  prev_stamp_ = c.stamp;
  last_inliers_ = inliers;
  last_points_.clear();
  for (long m : c.matches)
    if (m >= 0) last_points_.push_back(m);
  timings_.tracking_ms += ms_since(t1);

  return finish_tracked(c, res, recovered, inliers, doubts, true);
}

}  // namespace chungs::tracking
