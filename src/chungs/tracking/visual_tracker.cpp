#include "chungs/tracking/visual_tracker.hpp"

#include "chungs/common/stopwatch.hpp"

#include <chrono>
#include <exception>
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "chungs/common/log.hpp"
#include "chungs/tracking/pose_optimizer.hpp"

namespace chungs::tracking {

std::string doubt_names(uint32_t d) {
  static const std::pair<uint32_t, const char*> names[] = {{kDoubtFewInliers, "few_inliers"},
                                                           {kDoubtDisagree, "disagree"},
                                                           {kDoubtImplausible, "implausible"},
                                                           {kDoubtCoasting, "coasting"},
                                                           {kDoubtAmbiguous, "ambiguous"}};
  std::string out;
  for (auto& [bit, name] : names)
    if (d & bit) out += (out.empty() ? "" : "+") + std::string(name);
  return out;
}

const char* state_name(TrackState s) {
  switch (s) {
    case TrackState::Ok: return "ok";
    case TrackState::Recovered: return "recovered";
    case TrackState::Lost: return "lost";
  }
  return "?";
}

VisualTracker::VisualTracker(TrackerOptions opt) : opt_(std::move(opt)) {}
VisualTracker::~VisualTracker() = default;

std::string VisualTracker::why_not_started() const {
  if (!trajectory().empty()) return {};
  if (mono_)
    return cat("the tracker never started: no pair of its ", timings_.frames,
               " frames had the parallax and matches a monocular start needs");
  return cat("the tracker never started: a frame needs ", opt_.min_init_points,
             " features with depth to start the map, and the most any of its ", timings_.frames, " frames had was ",
             timings_.most_points_before_start);
}

std::string VisualTracker::describe() const {
  std::string out = cat("visual tracker (", mono_ ? "monocular" : stereo_ ? "stereo" : "rgb-d", "): ", map_.keyframes(),
                        " keyframes, ", map_.points(), " points, ", timings_.loops, " loop(s), ", timings_.lost_frames,
                        " lost frame(s)");
  if (mono_)
    out += cat(", ", timings_.map_segments, " map segment(s), ", timings_.reinitialisations, " re-initialisation(s)");
  return out;
}

double VisualTracker::close_depth() const {
  return stereo_ ? opt_.close_depth_baselines * baseline_ : opt_.rgbd_close_depth;
}

namespace {

// The baseline a frame's features are matched with: the stereo rig's, for RGB-D a virtual one, none (0) for a
// single camera.
double frame_baseline(const Frame& frame, const TrackerOptions& opt) {
  const Camera& cam = frame.camera;
  if (frame.right) {
    if (!(frame.baseline > 0)) fail("tracking: frame ", frame.index, " (", frame.source, ") has a right image but baseline ", frame.baseline);
    return frame.baseline;
  }
  if (frame.depth) {
    const double b = opt.rgbd_virtual_baseline > 0 ? opt.rgbd_virtual_baseline : 1.0 / (cam.fx * opt.rgbd_depth_noise);
    if (!std::isfinite(b) || !(b > 0))
      fail("tracking: RGB-D depth noise ", opt.rgbd_depth_noise, " with fx ", cam.fx, " gives no usable virtual baseline");
    return b;
  }
  return 0;
}

}  // namespace

std::shared_ptr<PreparedFrame> VisualTracker::prepare(const Frame& frame, const TrackerOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  auto out = std::make_shared<PreparedFrame>();
  out->index = frame.index;
  const double bf = frame.camera.fx * frame_baseline(frame, opt);
  // Below this ORB's border and pyramid leave nothing to match (and OpenCV throws on some sizes).
  constexpr int kMinSide = 32;
  if (frame.left.width() < kMinSide || frame.left.height() < kMinSide)
    fail("tracking: frame ", frame.index, " (", frame.source, ") is ", frame.left.width(), "x", frame.left.height(),
         ", below the ", kMinSide, "x", kMinSide, " that feature tracking needs");
  out->gray = to_gray_mat(frame.left);
  if (frame.right) {
    cv::Mat rg = to_gray_mat(*frame.right);
    Features rf;
    // The two images are independent: one core each. An exception may not leave an OpenMP region
    // (that ends the process), so each section keeps its own and the first is rethrown after it.
    std::exception_ptr errors[2];
#pragma omp parallel sections num_threads(2)
    {
#pragma omp section
      try {
        out->f = extract_orb(out->gray, opt.orb);
      } catch (...) {
        errors[0] = std::current_exception();
      }
#pragma omp section
      try {
        rf = extract_orb(rg, opt.orb);
      } catch (...) {
        errors[1] = std::current_exception();
      }
    }
    for (const auto& e : errors)
      if (e) {
        try {
          std::rethrow_exception(e);
        } catch (const std::exception& x) {
          fail("tracking: frame ", frame.index, " (", frame.source, "): feature extraction failed: ", x.what());
        }
      }
    match_stereo(out->gray, rg, out->f, rf, bf, opt.stereo);
  } else if (!frame.depth) {
    out->f = extract_orb(out->gray, opt.orb);
  } else {
    if (!frame.depth->same_size(frame.left)) fail("tracking: frame ", frame.index, " depth and image sizes differ");
    out->f = extract_orb(out->gray, opt.orb);
    attach_depth(*frame.depth, out->f, bf);
  }
  out->ms = ms_since(t0);
  return out;
}

void VisualTracker::extract(const Frame& frame, Current& c, std::shared_ptr<PreparedFrame> prepared) {
  const Camera& cam = frame.camera;
  const bool mono = !frame.right && !frame.depth;
  if (timings_.frames > 0 && mono != mono_)
    fail("tracking: frame ", frame.index, " (", frame.source, ") is ", mono ? "monocular" : "stereo or RGB-D",
         " but earlier frames were not: one sequence, one kind of input");
  mono_ = mono;
  stereo_ = bool(frame.right);
  baseline_ = frame_baseline(frame, opt_);
  if (width_ && (cam.width != width_ || cam.height != height_))
    fail("tracking: frame ", frame.index, " is ", cam.width, "x", cam.height, ", earlier frames ", width_, "x", height_);
  width_ = cam.width;
  height_ = cam.height;
  k_ = {cam.fx, cam.fy, cam.cx, cam.cy, cam.fx * baseline_};
  if (prepared && prepared->index != frame.index)
    fail("tracking: features prepared for frame ", prepared->index, " given with frame ", frame.index);
  if (prepared) {
    timings_.ahead_ms += prepared->ms;
  } else {
    prepared = prepare(frame, opt_);
    timings_.features_ms += prepared->ms;
  }
  c.gray = std::move(prepared->gray);
  c.f = std::move(prepared->f);
  c.matches.assign(c.f.size(), -1);
}

TrackResult VisualTracker::track(const Frame& frame) { return track(frame, nullptr); }

TrackResult VisualTracker::track(const Frame& frame, std::shared_ptr<PreparedFrame> prepared) {
  Current c;
  c.index = frame.index;
  c.stamp = frame.timestamp;
  extract(frame, c, std::move(prepared));
  auto t1 = std::chrono::steady_clock::now();
  ++timings_.frames;

  TrackResult res;
  res.frame_index = frame.index;
  res.stamp = frame.timestamp;
  if (mono_) return track_mono(c, res);
  if (map_.keyframes() == 0) {
    if (!initialize(c)) {
      res.state = TrackState::Lost;
      ++timings_.lost_frames;
      return res;
    }
    res.keyframe = true;
    res.keyframe_id = ref_kf_;
    res.pose = map_.pose(ref_kf_);
    res.inliers = int(map_.points());
    frames_.push_back({c.stamp, ref_kf_, SE3()});
    return res;
  }

  bool ok = false, recovered = false, coasting = false, bridged = false;
  uint32_t doubts = 0;
  bool have_prior = false;
  SE3 predicted;
  int motion = 0;
  bool measured_whole = false;
  // Within the frame-to-frame motion's tolerances of the predicted motion since the last frame.
  auto agrees_with = [&](const SE3& T_cw, const SE3& pred_cw) {
    const SE3 step = T_cw * last_T_cw_.inverse(), pred = pred_cw * last_T_cw_.inverse();
    const FrameMotionOptions fo;
    const double tol = fo.predict_translation + fo.predict_translation_share * pred.t.norm();
    return (step.t - pred.t).norm() < tol && step.q.angularDistance(pred.q) * 180 / M_PI < fo.predict_rotation_deg;
  };
  // Closer: the frame-to-frame motion measures the step to a few centimetres.
  auto agrees_closely = [&](const SE3& T_cw, const SE3& pred_cw) {
    const SE3 step = T_cw * last_T_cw_.inverse(), pred = pred_cw * last_T_cw_.inverse();
    return (step.t - pred.t).norm() < 0.1 + 0.1 * pred.t.norm() && step.q.angularDistance(pred.q) * 180 / M_PI < 2;
  };
  bool measured = false;
  FrameMotion fm;
  if (!lost_ && prev_valid_) {
    // The static world's motion since the last frame, with features on other motions (a vehicle crossing
    // ahead) set aside: they stay out of every pose estimate and out of new map points.
    const SE3 vel = velocity_ ? *velocity_ : SE3();
    fm = estimate_frame_motion(prev_f_, c.f, k_, width_, height_, {}, velocity_ ? &vel : nullptr);
    if (fm.moving_features) c.moving = fm.moving;
    log::debug("tracking: frame ", c.index, " frame-to-frame: ", fm.matches, " matches, ", fm.motions, " motion(s), ",
               fm.inliers, " inliers over ", fm.cells, " cells and ", fm.depth_bins, " depths, ", fm.moving_features,
               " features moving; camera moved (", (fm.T_cp.inverse().t.transpose()), ")", fm.disagrees ? ", disagrees" : "");
  }
  if (!lost_) {
    // Prediction: the measured frame-to-frame motion when it is well supported, else constant velocity.
    // A frame-to-frame motion that disagrees with constant velocity is taken only when it is the static
    // world seen whole (the prediction was coasting or the vehicle changed its motion).
    measured = fm.ok && fm.inliers >= 2 * opt_.min_inliers && (!fm.disagrees || fm.whole_view);
    predicted = measured ? fm.T_cp * last_T_cw_ : velocity_ ? *velocity_ * last_T_cw_ : last_T_cw_;
    have_prior = measured || velocity_.has_value();
    measured_whole = measured && fm.whole_view;
    if (fm.ok && (fm.runner_up_inliers >= fm.inliers / 2 || fm.chosen_without_prediction)) doubts |= kDoubtAmbiguous;
    if (fm.disagrees) doubts |= kDoubtDisagree;
    motion = track_motion(c, predicted);
    const SE3 motion_pose = c.T_cw;
    ok = motion >= opt_.min_inliers;
    // A sudden turn moves the image further than the motion model's search window: the few matches it then
    // finds are wrong ones that agree by chance. Far fewer inliers than the last frame had means the
    // prediction is doubtful, so PnP on descriptor matches (no prior) gets a chance and the better one wins.
    if (!ok || motion < opt_.motion_check_ratio * last_inliers_) {
      log::debug("tracking: frame ", c.index, " motion model gave ", motion, " inliers (last frame ", last_inliers_,
                 "), trying PnP against the local map");
      Current alt;
      alt.index = c.index;
      alt.f = c.f;
      alt.T_cw = last_T_cw_;
      alt.matches.assign(c.f.size(), -1);
      alt.moving = c.moving;
      auto kfs = keyframes_seeing(last_points_);
      if (kfs.empty()) kfs.push_back(ref_kf_);
      if (track_pnp(alt, kfs)) {
        const int n = int(std::count_if(alt.matches.begin(), alt.matches.end(), [](long m) { return m >= 0; }));
        // Cross-check: with a prediction to go by, a PnP pose that moved far from it (the matches of a
        // vehicle crossing ahead agree with each other too) replaces a working motion-model pose only
        // when it agrees with the prediction.
        const bool plausible = !have_prior || agrees_with(alt.T_cw, predicted);
        if (plausible && (!ok || n > motion)) {
          c.T_cw = alt.T_cw;
          c.matches = std::move(alt.matches);
          ok = true;
        } else if (!plausible) {
          log::debug("tracking: frame ", c.index, " PnP pose disagrees with the prediction: not taken");
          doubts |= kDoubtDisagree;
        }
      }
    }
    if (!ok && measured) {
      // The map lost sight of the static world (behind a vehicle that filled the view) but the frame-to-frame
      // motion measures it: bridge with that motion and make a keyframe to map what is seen now.
      bridged = true;
      c.T_cw = predicted;
      log::debug("tracking: frame ", c.index, " bridged by the frame-to-frame motion (", fm.inliers, " inliers)");
    } else if (!ok && have_prior && coast_frames_ < opt_.max_coast_frames) {
      // The static world could not be measured (a vehicle filling the view): keep to the prediction, or to
      // the motion model's pose where the few matches it had agree with it. Doubtful, and no keyframe.
      coasting = true;
      c.T_cw = motion >= 8 && agrees_with(motion_pose, predicted) ? motion_pose : predicted;
      log::debug("tracking: frame ", c.index, " coasting on the prediction (", motion, " motion-model inliers)");
    }
  } else {
    // Relocalisation: every keyframe is a candidate, the newest first.
    std::vector<long> kfs;
    for (long i = long(map_.keyframes()) - 1; i >= 0; --i)
      if (!map_.kf(i).bad) kfs.push_back(i);
    ok = track_pnp(c, kfs);
    recovered = ok;
  }
  const int pose_inliers = ok ? int(std::count_if(c.matches.begin(), c.matches.end(), [](long m) { return m >= 0; })) : 0;
  int inliers = ok ? track_local_map(c) : coasting || bridged ? motion : 0;
  log::debug("tracking: frame ", c.index, ": ", pose_inliers, " inliers from the first pose, ", inliers, " after the local map");
  if (ok && have_prior && inliers < 2 * opt_.confident_inliers && !agrees_with(c.T_cw, predicted) &&
      !measured_whole && coast_frames_ < opt_.max_coast_frames) {
    // A weakly supported pose far from the prediction (a few static points left beside a vehicle that fills
    // the view constrain it poorly): the prediction is the better guess.
    log::debug("tracking: frame ", c.index, " pose on ", inliers, " inliers disagrees with the prediction: coasting");
    coasting = true;
    c.T_cw = predicted;
  }
  if (ok && !coasting && measured && (fm.moving_features > 0 || fm.disagrees) && !agrees_closely(c.T_cw, predicted)) {
    // Something moves in view and the map-based pose left the measured static motion: map points on the
    // moving object (made before it was seen to move) pulled it. The measured motion stands.
    log::debug("tracking: frame ", c.index, " map pose left the measured motion beside a moving object: taking the motion");
    doubts |= kDoubtDisagree;
    c.T_cw = predicted;
    inliers = 0;
    for (size_t i = 0; i < c.matches.size(); ++i) {
      const MapPoint* p = c.matches[i] >= 0 ? map_.point(c.matches[i]) : nullptr;
      const auto& kp = c.f.kps[i];
      if (p && reprojection_chi2(k_, c.T_cw.q, c.T_cw.t, p->pos, kp.pt.x, kp.pt.y, c.f.u_right[i],
                                 1.0 / level_scale(kp.octave, opt_.orb.scale_factor)) <= kChi2Stereo)
        ++inliers;
      else
        c.matches[i] = -1;
    }
  }
  if (ok && !coasting && inliers < opt_.min_inliers && measured_whole && have_prior) {
    // The local map failed where the static world is seen whole frame to frame: bridge (as above).
    bridged = true;
    c.T_cw = predicted;
    std::fill(c.matches.begin(), c.matches.end(), -1);
    inliers = 0;
  }
  ok = coasting || bridged || (ok && inliers >= opt_.min_inliers);
  timings_.tracking_ms += ms_since(t1);

  prev_valid_ = ok;
  if (ok) prev_f_ = c.f;
  if (!ok) {
    if (!lost_) log::warn("tracking: lost at frame ", c.index, " (", inliers, " inliers)");
    lost_ = true;
    last_inliers_ = 0;
    velocity_.reset();
    ++timings_.lost_frames;
    res.state = TrackState::Lost;
    res.pose = last_T_cw_.inverse();
    res.keyframe_id = ref_kf_;
    frames_.push_back({c.stamp, ref_kf_, map_.pose(ref_kf_).inverse() * res.pose});
    return res;
  }
  if (lost_) log::info("tracking: relocalised at frame ", c.index, " with ", inliers, " inliers");
  lost_ = false;
  // Confidence: the estimate against the prediction, its support and the motion it implies.
  const SE3 step = c.T_cw * last_T_cw_.inverse();
  if (coasting) {
    doubts |= kDoubtCoasting;
    ++coast_frames_;
    ++timings_.coasted_frames;
  } else {
    coast_frames_ = 0;
    if (bridged) doubts |= kDoubtFewInliers;
    if (have_prior && !agrees_with(c.T_cw, predicted)) doubts |= kDoubtDisagree;
    if (inliers < opt_.confident_inliers) doubts |= kDoubtFewInliers;
  }
  const double dt = c.stamp - prev_stamp_;
  const Eigen::Vector3d moved = step.inverse().t;  // in the previous camera's frame: x sideways, z forwards
  if (!recovered && dt > 0 &&
      (moved.norm() > opt_.max_speed * dt ||
       std::abs(moved.x()) > std::max(opt_.max_sideways_speed * dt, std::abs(moved.z())) ||
       step.q.angularDistance(Eigen::Quaterniond::Identity()) * 180 / M_PI > opt_.max_turn_rate * dt))
    doubts |= kDoubtImplausible;
  if (doubts) {
    ++timings_.doubtful_frames;
    log::debug("tracking: frame ", c.index, " doubtful: ", doubt_names(doubts));
  }
  velocity_ = step;
  last_T_cw_ = c.T_cw;
  prev_stamp_ = c.stamp;
  if (!coasting) {
    last_inliers_ = inliers;
    last_points_.clear();
    for (long m : c.matches)
      if (m >= 0) last_points_.push_back(m);
  }

  return finish_tracked(c, res, recovered, inliers, doubts, !coasting);
}

TrackResult VisualTracker::finish_tracked(Current& c, TrackResult res, bool recovered, int inliers, uint32_t doubts,
                                          bool may_make_keyframe) {
  res.state = recovered ? TrackState::Recovered : TrackState::Ok;
  res.inliers = inliers;
  res.doubts = doubts;
  const auto t2 = std::chrono::steady_clock::now();
  if (may_make_keyframe && need_keyframe(c, inliers)) {
    res.keyframe = true;
    const size_t before = ops_.size();
    create_keyframe(c);
    for (size_t k = before; k < ops_.size(); ++k)
      if (ops_[k].kind == MapOperation::Kind::NewKeyframe) ops_[k].keyframe.doubts = doubts;
  }
  timings_.keyframe_ms += ms_since(t2);
  res.keyframe_id = ref_kf_;
  res.pose = c.T_cw.inverse();
  frames_.push_back({c.stamp, ref_kf_, map_.pose(ref_kf_).inverse() * res.pose});
  return res;
}

bool VisualTracker::initialize(Current& c) {
  int with_depth = 0;
  for (size_t i = 0; i < c.f.size(); ++i) with_depth += c.f.has_depth(i);
  if (with_depth < opt_.min_init_points) {
    timings_.most_points_before_start = std::max(timings_.most_points_before_start, with_depth);
    log::info("tracking: frame ", c.index, " has ", with_depth, " features with depth, waiting for ", opt_.min_init_points);
    return false;
  }
  c.T_cw = SE3();
  last_T_cw_ = c.T_cw;
  prev_f_ = c.f;
  prev_valid_ = true;
  prev_stamp_ = c.stamp;
  create_keyframe(c);
  return true;
}

int VisualTracker::optimize(Current& c) {
  std::vector<PoseObservation> obs;
  std::vector<int> idx;
  for (size_t i = 0; i < c.matches.size(); ++i) {
    if (c.matches[i] < 0) continue;
    const MapPoint* p = map_.point(c.matches[i]);
    if (p && c.is_moving(i)) {
      // A map point on something that moves (made before it was seen to move): out of the map.
      map_.erase_point(c.matches[i]);
      p = nullptr;
    }
    if (!p) {
      c.matches[i] = -1;
      continue;
    }
    const auto& kp = c.f.kps[i];
    obs.push_back({p->pos, kp.pt.x, kp.pt.y, c.f.u_right[i], 1.0 / level_scale(kp.octave, opt_.orb.scale_factor)});
    idx.push_back(int(i));
  }
  std::vector<char> inlier;
  int n = optimize_pose(c.T_cw, k_, obs, inlier);
  for (size_t j = 0; j < idx.size(); ++j)
    if (!inlier[j]) c.matches[idx[j]] = -1;
  return n;
}

int VisualTracker::track_motion(Current& c, const SE3& predicted) {
  c.T_cw = predicted;
  FeatureGrid grid(c.f.kps, width_, height_);
  ProjectionSearch s;
  s.radius = 15;
  search_by_projection(map_, last_points_, c.T_cw, k_, width_, height_, c.f, grid, c.matches, s);
  int found = 0;
  for (long m : c.matches) found += m >= 0;
  if (found < opt_.min_inliers) {
    // A sudden change of motion: search wider before giving up on the prediction.
    std::fill(c.matches.begin(), c.matches.end(), -1);
    s.radius = 40;
    search_by_projection(map_, last_points_, c.T_cw, k_, width_, height_, c.f, grid, c.matches, s);
  }
  return optimize(c);
}

}  // namespace chungs::tracking
