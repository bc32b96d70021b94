#include "chungs/pipeline/tracker_feed.hpp"

#include <thread>
#include <unordered_set>
#include <vector>

#include "chungs/common/blocking_queue.hpp"
#include "chungs/common/error.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/eval/trajectory_metrics.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/tracking/visual_tracker.hpp"

namespace chungs {

namespace {

using tracking::MapOperation;

class TrackerFeed : public FrameFeed {
 public:
  TrackerFeed(const Dataset& dataset, size_t n, const MapperConfig& config, const tracking::TrackerOptions& options)
      : dataset_(dataset), n_(n), holdout_every_(config.holdout_every), tracker_(options) {
    loader_ = std::thread([this] { load(); });
    thread_ = std::thread([this] { run(); });
  }
  ~TrackerFeed() override {
    stop_ = true;
    frames_.close();  // releases the loader if it waits for room
    if (thread_.joinable()) thread_.join();
    if (loader_.joinable()) loader_.join();
  }

  std::optional<FeedItem> next() override { return queue_.pop(); }
  bool ready() const override { return queue_.ready(); }

  std::vector<std::optional<SE3>> final_poses() override {
    if (thread_.joinable()) thread_.join();
    std::vector<std::optional<SE3>> out(n_);
    const Trajectory est = tracker_.trajectory();
    // The tracker keeps one pose per tracked frame, by stamp; frames are matched by exact stamp.
    const auto pairs = associate_stamps(stamps_, est.stamps, 1e-6);
    for (auto [i, k] : pairs) out[i] = est.poses[k];
    return out;
  }

  std::string why_no_pose() override {
    if (thread_.joinable()) thread_.join();  // the tracker's state is read once its thread has ended
    return tracker_.why_not_started();
  }

  nlohmann::json report() const override {
    const auto& t = tracker_.timings();
    nlohmann::json j = {{"tracker", tracker_.describe()}, {"frames", t.frames},
                        {"keyframes", t.keyframes},       {"lost_frames", lost_},
                        {"loop_closures", loops_},        {"doubtful_frames", doubtful_count_},
                        {"doubtful_keyframes_not_mapped", doubtful_keyframes_}};
    if (t.map_segments) {
      j["map_segments"] = t.map_segments;
      j["reinitialisations"] = t.reinitialisations;
    }
    // The first ones by frame index (all of them on any excerpt a user would read through).
    j["doubtful_frame_list"] = doubtful_;
    j.update(tracker_time_report(t));
    if (gt_.size() >= 3) {
      // A single camera measures no scale (issue 25): its trajectory is compared after a similarity alignment.
      const bool mono = !dataset_.info().has_right && !dataset_.info().has_depth;
      const AteResult ate = compute_ate(gt_, tracker_.trajectory(), {mono ? Alignment::Sim3 : Alignment::SE3, 0.02});
      j["ate"] = to_json(ate);
      j["gt_path_length_m"] = gt_.path_length();
    }
    return j;
  }

 private:
  // Reading and decoding a frame's images and extracting its features add to the tracker's own time
  // per frame, which at KITTI's full resolution is close to the 10 Hz intake: frames ahead, on a
  // thread of their own.
  void load() {
    try {
      for (size_t i = 0; i < n_ && !stop_; ++i) {
        Ahead a{dataset_.frame(i), nullptr};
        a.features = tracking::VisualTracker::prepare(a.frame, tracker_.options());
        if (!frames_.push(std::move(a))) return;
      }
      frames_.close();
    } catch (...) {
      frames_.fail(std::current_exception());
    }
  }

  void run() {
    try {
      for (size_t i = 0; i < n_ && !stop_; ++i) {
        std::optional<Ahead> next = frames_.pop();
        if (!next) break;  // stopped
        const Frame& frame = next->frame;
        const tracking::TrackResult r = tracker_.track(frame, std::move(next->features));
        stamps_.push_back(frame.timestamp);
        if (frame.gt_pose) gt_.push_back(frame.timestamp, *frame.gt_pose);
        FeedItem item;
        item.frame = i;
        item.pose = r.pose;
        lost_ += r.state == tracking::TrackState::Lost;
        // A keyframe from a doubtful pose (issue 23: few inliers, estimates that disagree, implausible
        // motion, coasting behind a vehicle) would put Gaussians where the world is not: the tracker
        // keeps it for its own map, the Gaussian map does not take it.
        if (r.doubtful()) {
          if (doubtful_count_++ < kListedDoubtful) doubtful_.push_back(i);
          doubtful_keyframes_ += r.keyframe && !is_held_out(i, holdout_every_);
        }
        item.keyframe = r.keyframe && !r.doubtful() && !is_held_out(i, holdout_every_);
        item.keyframe_id = r.keyframe ? r.keyframe_id : -1;
        for (MapOperation& op : tracker_.take_map_operations()) {
          if (op.kind == MapOperation::Kind::NewKeyframe) {
            // The frame's own result says whether it is a keyframe; its record brings the points.
            // Another keyframe (a monocular segment's first view) is a sweep neighbour, unless its frame
            // is held out (never seen by the map) or its pose doubtful.
            if (r.keyframe && op.keyframe.id == r.keyframe_id)
              take_points(op.keyframe, item);
            else if (!is_held_out(op.keyframe.frame_index, holdout_every_) && op.keyframe.doubts == 0)
              item.sweep_views.push_back({op.keyframe.frame_index, op.keyframe.id, op.keyframe.pose});
            continue;
          }
          loops_ += op.kind == MapOperation::Kind::LoopClosure;
          item.updates.push_back(pose_update_of(op));
        }
        queue_.push(std::move(item));
      }
      queue_.close();
    } catch (...) {
      queue_.fail(std::current_exception());
    }
  }

  // The keyframe's map points: all of them for its depth prior, and those no mapped keyframe has
  // handed over yet as seeds (a point is seen by many keyframes and would otherwise be seeded by each).
  void take_points(const tracking::KeyframeRecord& kf, FeedItem& item) {
    item.map_points = kf.points;
    if (!item.keyframe) return;  // not mapped: its points stay for a keyframe that is
    for (size_t k = 0; k < kf.points.size() && k < kf.point_ids.size(); ++k)
      if (seeded_.insert(kf.point_ids[k]).second) item.seeds.push_back(kf.points[k]);
  }

  const Dataset& dataset_;
  std::unordered_set<long> seeded_;  // map point ids handed over as seeds (tracking thread)
  size_t n_;
  int holdout_every_;
  tracking::VisualTracker tracker_;
  BlockingQueue<FeedItem> queue_;
  struct Ahead {
    Frame frame;
    std::shared_ptr<tracking::PreparedFrame> features;
  };
  BlockingQueue<Ahead> frames_{2};  // read (and their features extracted) ahead of the tracker
  std::thread loader_, thread_;
  std::atomic<bool> stop_{false};
  // Written by the tracking thread; read after it has ended (final_poses, report).
  std::vector<double> stamps_;
  Trajectory gt_;
  size_t lost_ = 0, loops_ = 0, doubtful_count_ = 0, doubtful_keyframes_ = 0;
  std::vector<size_t> doubtful_;  // frame indices, the first kListedDoubtful
  static constexpr size_t kListedDoubtful = 1000;
};

}  // namespace

PoseUpdate pose_update_of(const tracking::MapOperation& op) {
  PoseUpdate u;
  if (op.kind == tracking::MapOperation::Kind::LoopClosure) {
    u.loop = true;
    u.query = op.loop.query;
    u.match = op.loop.match;
    u.poses = op.loop.new_poses;
    u.junction = op.loop.junction;
  } else {
    u.poses = op.poses;
  }
  return u;
}

nlohmann::json tracker_time_report(const tracking::TrackerTimings& t) {
  // The tracker thread's own time: features extracted ahead on the reader thread are not in it.
  const double n = double(std::max<size_t>(t.frames, 1));
  nlohmann::json j = {{"tracking_ms_per_frame", (t.features_ms + t.tracking_ms + t.keyframe_ms) / n}};
  if (t.frames)
    j["tracking_ms"] = {{"features", t.features_ms / n}, {"features_ahead", t.ahead_ms / n},
                        {"pose", t.tracking_ms / n},     {"keyframes", t.keyframe_ms / n},
                        {"keyframe_ba", t.ba_ms / n},    {"keyframe_loop", t.loop_ms / n}};
  return j;
}

std::unique_ptr<FrameFeed> make_tracker_feed(const Dataset& dataset, size_t n, const MapperConfig& config,
                                             const tracking::TrackerOptions& options) {
  return std::make_unique<TrackerFeed>(dataset, n, config, options);
}

}  // namespace chungs
