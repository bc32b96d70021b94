// LiveMapper: frames arrive one at a time with their pose; keyframes are chosen by the rule the
// given-pose run uses (mapper.keyframe_*), loaded at the mapping resolution with the same depth
// source as `diskchungs run` (load_mapping_frame on a one-frame dataset), and trained the same way,
// so a recording played into the node makes the map `run --dataset` makes of it.
#include "ros/engine/live_mapper.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/common/heap.hpp"
#include "chungs/common/log.hpp"
#include "chungs/common/process_defaults.hpp"
#include "chungs/config/config.hpp"
#include "chungs/config/presets.hpp"
#include "chungs/datasets/rosbag_images.hpp"
#include "chungs/depth/depth_source.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/pipeline/checkpoint_cadence.hpp"
#include "chungs/pipeline/frame_feed.hpp"
#include "chungs/pipeline/frame_source.hpp"
#include "chungs/pipeline/ply_export.hpp"
#include "chungs/pipeline/pose_updates.hpp"
#include "chungs/pipeline/resume_point.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/pipeline/tracker_feed.hpp"
#include "chungs/store/chunk_id.hpp"
#include "chungs/store/chunk_levels.hpp"
#include "chungs/store/chunk_store.hpp"
#include "chungs/tracking/visual_tracker.hpp"

namespace chungs::live {

namespace {

using Clock = std::chrono::steady_clock;

SE3 to_se3(const rosbag_io::Pose& p) {
  return SE3(Eigen::Quaterniond(p.q[3], p.q[0], p.q[1], p.q[2]).normalized(),
             Eigen::Vector3d(p.t[0], p.t[1], p.t[2]));
}

rosbag_io::Pose to_pose(const SE3& p) {
  return {{p.t.x(), p.t.y(), p.t.z()}, {p.q.x(), p.q.y(), p.q.z(), p.q.w()}};
}

// One received frame as a dataset, so that scaling and depth go through the offline run's code.
class OneFrame : public Dataset {
 public:
  explicit OneFrame(Frame f) : frame_(std::move(f)) {
    info_.kind = "live";
    info_.frames = 1;
    info_.camera = frame_.camera;
    info_.baseline = frame_.baseline;
    info_.has_right = frame_.right.has_value();
    info_.has_depth = frame_.depth.has_value();
    info_.color = frame_.left.channels() == 3;
  }
  const DatasetInfo& info() const override { return info_; }
  Frame frame(size_t) const override { return frame_; }
  double timestamp(size_t) const override { return frame_.timestamp; }
  std::optional<SE3> gt_pose(size_t) const override { return frame_.gt_pose; }

 private:
  Frame frame_;
  DatasetInfo info_;
};

// Settings::max_queue resolved: a live source under anytime pacing with given poses waits no longer
// than `run` reads ahead (mapper.frame_lookahead, at least one frame), so the map follows the robot
// and memory stays bounded; fixed pacing maps every frame, and the tracker needs every frame.
size_t queue_bound(const Settings& s, const MapperConfig& mc) {
  if (s.max_queue < -1)
    fail("max_queue must be -1 (automatic), 0 (no bound) or a count of frames, got ", s.max_queue);
  if (s.max_queue >= 0) return size_t(s.max_queue);
  if (mc.pacing != "anytime" || s.track) return 0;
  return size_t(std::max(mc.frame_lookahead, 1));
}

// A lock granted in the order it was asked for. The mapping thread takes the map's lock for one step
// at a time and, under anytime pacing, asks again at once: with std::mutex it won again and again, so
// the node's status, renders and clouds waited seconds (a test saw no status for minutes), and so did
// its shutdown, which waits for them (roslaunch's SIGTERM 15 s after Ctrl-C then lost the map since
// its last commit). Here a query waits for one step at most.
class TurnLock {
 public:
  void lock() {
    std::unique_lock l(m_);
    const uint64_t ticket = next_++;
    cv_.wait(l, [&] { return serving_ == ticket; });
  }
  void unlock() {
    {
      std::lock_guard l(m_);
      ++serving_;
    }
    cv_.notify_all();
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  uint64_t next_ = 0, serving_ = 0;
};

}  // namespace

struct LiveMapper::Impl {
  Settings settings;
  Config config;
  std::unique_ptr<Mapper> mapper;
  // Settings::track: the tracker runs on the mapping thread over every frame, held-out ones too; its
  // bundle adjustment and loop closures reach the map as in `run --poses track`.
  std::unique_ptr<tracking::VisualTracker> tracker;
  std::unique_ptr<PoseUpdateApplier> updates;
  // The mapper is single-threaded: the mapping thread and the node's queries take turns, in the order
  // they asked.
  TurnLock map_mutex;

  std::mutex queue_mutex;
  std::condition_variable queue_cv;
  std::deque<LiveFrame> queue;
  bool finishing = false, finished = false;
  std::thread worker;
  // Settings::track: the tracker's own thread tracks every frame as it comes and hands each frame's
  // result to the mapping thread through `decided` (guarded by queue_mutex, as the flags below), so a
  // mapper behind its intake drops keyframes, as `run` does, instead of the tracker losing frames.
  std::thread tracking;
  bool being_tracked = false, tracking_done = false, failed = false;
  std::string error;

  // The next frame's number. Taken with queue_mutex held (a frame taken off the queue, or dropped from
  // it), read without it by commits: atomic.
  std::atomic<uint64_t> next_frame{0};
  uint64_t dropped = 0, corrected = 0, without_pose = 0;
  size_t queue_bound = 0;  // frames waiting at most, the oldest dropped beyond it (0: no bound)
  // The fewest steps any keyframe got before its successor came (guarded by map_mutex).
  std::optional<uint64_t> least_steps;
  std::optional<SE3> last_keyframe;
  size_t since_keyframe = 0;
  double scene_depth = 0;
  size_t keyframes_since_checkpoint = 0;
  Clock::time_point started = Clock::now(), last_checkpoint = Clock::now();
  double carried_seconds = 0;
  uint64_t rate_iterations = 0;
  Clock::time_point rate_at = Clock::now();
  double steps_per_s = 0;

  double seconds() const {
    return carried_seconds + std::chrono::duration<double>(Clock::now() - started).count();
  }

  nlohmann::json state(bool done) const {
    // "track" as `run --poses track`: such a map lies in its first camera's frame (render says so).
    return {{"dataset", settings.source},
            {"poses", settings.track ? "track" : "external"},
            {"resolution", config.mapper.resolution},
            {"next_frame", next_frame.load()},
            {"frames", next_frame.load()},
            {"finished", done},
            {"seconds", seconds()}};
  }

  // The given-pose run's keyframe rule (pipeline/frame_feed.cpp), on frames as they come.
  bool is_keyframe(const SE3& pose) {
    const MapperConfig& c = config.mapper;
    ++since_keyframe;
    bool key = !last_keyframe;
    if (last_keyframe) {
      const double moved = (pose.t - last_keyframe->t).norm();
      key = (c.keyframe_every > 0 && since_keyframe >= size_t(c.keyframe_every)) ||
            (c.keyframe_translation > 0 && moved >= c.keyframe_translation) ||
            (c.keyframe_parallax > 0 && moved >= c.keyframe_parallax * scene_depth && moved > 0) ||
            (c.keyframe_rotation_deg > 0 &&
             (last_keyframe->inverse() * pose).angle() * 180.0 / M_PI >= c.keyframe_rotation_deg);
    }
    if (key) {
      since_keyframe = 0;
      last_keyframe = pose;
    }
    return key;
  }

  // A frame's pose (given, or the tracker's), whether it becomes a keyframe, and the tracker's pose
  // updates that came with it.
  struct Decided {
    Frame frame;
    uint64_t index = 0;
    double stamp = 0;
    SE3 pose;
    bool key = false;
    long source_id = 0;
    std::vector<PoseUpdate> pending;
  };
  std::deque<Decided> decided;

  // Stage one (the tracker's thread with Settings::track, else the mapping thread): frame number i's
  // pose and role. None for a frame that has no part in the map (no pose, held out).
  std::optional<Decided> decide(const LiveFrame& in, uint64_t i) {
    if (in.left.width == 0) return std::nullopt;  // skip(): a frame without a pose, counted in order
    Frame f;
    f.index = i;
    f.timestamp = in.stamp;
    f.left = rosbag_io::image_of(in.left);
    if (in.right) f.right = rosbag_io::image_of(*in.right);
    if (in.depth) f.depth = rosbag_io::depth_of(*in.depth);
    f.camera = Camera(in.left.width, in.left.height, in.fx, in.fy, in.cx, in.cy);
    f.baseline = in.baseline;
    f.source = cat(settings.source, " frame ", i);
    // Held out as in `diskchungs run`, so a recording's map can be scored on frames it never saw.
    const bool held_out = is_held_out(i, config.mapper.holdout_every);
    SE3 pose;
    bool key = false;
    long source_id = long(i);
    std::vector<PoseUpdate> pending;
    if (tracker) {
      const tracking::TrackResult r = tracker->track(f);
      pose = r.pose;
      // A doubtful pose makes no keyframe of the map (the tracker keeps it for its own), as in `run`.
      key = r.keyframe && !r.doubtful() && !held_out;
      source_id = r.keyframe_id;
      for (const tracking::MapOperation& op : tracker->take_map_operations())
        if (op.kind != tracking::MapOperation::Kind::NewKeyframe) pending.push_back(pose_update_of(op));
    } else {
      if (held_out) return std::nullopt;
      if (!in.pose) fail(settings.source, " frame ", i, ": no pose");
      pose = to_se3(*in.pose);
      key = is_keyframe(pose);
    }
    return Decided{std::move(f), i, in.stamp, pose, key, source_id, std::move(pending)};
  }

  // Stage two (the mapping thread): the keyframe into the map unless `drop` (a later one supersedes
  // it), then the tracker's pose updates in order, whatever became of the keyframe.
  void map_decided(Decided d, bool drop) {
    const bool add = d.key && !drop;
    if (add) add_keyframe(std::move(d.frame), d.index, d.stamp, d.pose, d.source_id);
    if (!d.pending.empty()) {
      PoseUpdateApplier::Applied applied;
      {
        std::lock_guard lock(map_mutex);
        applied = updates->apply(d.pending);
      }
      if (applied.loop) commit(false, true);
    }
    if (!add) return;
    const MapperConfig& mc = config.mapper;
    // Fixed pacing: its steps. Anytime: the floor, as `run` keeps it; without it a node behind its
    // intake mapped frame after frame with no step between them, and the map filled with Gaussians
    // never trained (issue 19's starvation).
    const int steps = mc.pacing == "fixed" ? mc.iterations_per_keyframe : mc.min_steps_per_keyframe;
    for (int k = 0; k < steps; ++k) step();
    const double since_checkpoint = std::chrono::duration<double>(Clock::now() - last_checkpoint).count();
    IoStats io;
    {
      std::lock_guard lock(map_mutex);
      io = mapper->io_stats();
    }
    // The same cadence as `run`, so checkpoint_max_share bounds a live map's checkpoints too.
    if (checkpoint_due(mc, since_checkpoint, keyframes_since_checkpoint,
                       std::chrono::duration<double>(Clock::now() - started).count(), io))
      commit(false, true);
  }

  // Loads the keyframe at the mapping resolution with `run`'s depth source and adds it to the map.
  void add_keyframe(Frame f, uint64_t i, double stamp, const SE3& pose, long source_id) {
    OneFrame one(std::move(f));
    const MapperConfig& mc = config.mapper;
    const DepthMode mode =
        resolve_depth_mode(parse_depth_mode(mc.depth), one.info().has_depth, one.info().has_right);
    StereoDepthConfig stereo = config.stereo;
    stereo.cuda = mapper->device() == "cuda";
    MappingFrame m = load_mapping_frame(one, 0, mc.resolution, mode, stereo);
    if (m.median_depth > 0 && std::isfinite(m.median_depth)) scene_depth = m.median_depth;
    {
      std::lock_guard lock(map_mutex);
      // The steps the previous keyframe got before this one came (the floor, or starvation, in numbers).
      if (!mapper->keyframes().empty()) {
        const uint64_t got = mapper->steps_since_keyframe();
        least_steps = std::min(least_steps.value_or(got), got);
      }
      mapper->add_keyframe(i, stamp, m.frame.left, m.depth, m.frame.camera, pose);
      if (updates) updates->added(source_id, mapper->keyframes().back().id);
    }
    ++keyframes_since_checkpoint;
  }

  // One step; false (and none) before the first keyframe. One turn of the map's lock, which the idle
  // loop of anytime pacing takes step after step.
  bool step() {
    std::lock_guard lock(map_mutex);
    if (mapper->keyframes().empty()) return false;
    mapper->step();
    return true;
  }

  void commit(bool done, bool behind) {
    std::lock_guard lock(map_mutex);
    mapper->checkpoint(state(done), behind);
    keyframes_since_checkpoint = 0;
    last_checkpoint = Clock::now();
  }

  std::string dropped_note() {
    std::lock_guard lock(queue_mutex);
    return dropped ? cat(" (", dropped, " dropped: the mapper was behind its intake)") : std::string();
  }

  size_t keyframe_count() {
    std::lock_guard lock(map_mutex);
    return mapper->keyframes().size();
  }
  bool has_keyframes() { return keyframe_count() > 0; }

  // The tracker's thread (Settings::track): every frame in order, never waiting for the mapper.
  void track_frames() {
    try {
      while (true) {
        std::optional<LiveFrame> frame;
        uint64_t index = 0;
        {
          std::unique_lock lock(queue_mutex);
          queue_cv.wait(lock, [&] { return !queue.empty() || finishing || failed; });
          if (failed || queue.empty()) break;
          frame = std::move(queue.front());
          queue.pop_front();
          index = next_frame++;
          being_tracked = true;
        }
        std::optional<Decided> d = decide(*frame, index);
        {
          std::lock_guard lock(queue_mutex);
          being_tracked = false;
          if (d) decided.push_back(std::move(*d));
        }
        queue_cv.notify_all();
      }
    } catch (const std::exception& e) {
      std::lock_guard lock(queue_mutex);
      error = e.what();
      failed = true;
      log::error("tracking stopped: ", e.what());
    }
    {
      std::lock_guard lock(queue_mutex);
      tracking_done = true;
    }
    queue_cv.notify_all();
  }

  void note_dropped_keyframe() {
    std::lock_guard lock(queue_mutex);
    if (dropped++ == 0)
      log::warn(
          "the mapper is behind the tracker: a keyframe that a later one supersedes is dropped, as in "
          "`run` (the status counts them)");
  }

  void run() {
    try {
      const bool anytime = config.mapper.pacing == "anytime";
      while (true) {
        std::optional<LiveFrame> frame;
        std::optional<Decided> tracked;
        uint64_t index = 0;
        bool drop = false;
        {
          std::unique_lock lock(queue_mutex);
          // Anytime pacing trains while no frame waits; fixed pacing trains only per keyframe.
          if (tracker) {
            if (!anytime) queue_cv.wait(lock, [&] { return !decided.empty() || tracking_done; });
            if (!decided.empty()) {
              tracked = std::move(decided.front());
              decided.pop_front();
              drop = anytime && tracked->key &&
                     std::any_of(decided.begin(), decided.end(), [](const Decided& d) { return d.key; });
            } else if (tracking_done) {
              break;
            }
          } else {
            if (!anytime) queue_cv.wait(lock, [&] { return !queue.empty() || finishing; });
            if (!queue.empty()) {
              frame = std::move(queue.front());
              queue.pop_front();
              index = next_frame++;
            } else if (finishing) {
              break;
            }
          }
        }
        if (tracked) {
          if (drop) note_dropped_keyframe();
          map_decided(std::move(*tracked), drop);
        } else if (frame) {
          if (std::optional<Decided> d = decide(*frame, index)) map_decided(std::move(*d), false);
        } else if (!step()) {
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
      }
      bool tracking_failed = false;
      {
        std::lock_guard lock(queue_mutex);
        tracking_failed = failed;
      }
      if (tracking_failed) {
        // The error is the status's; what was mapped is kept, unfinished.
        if (has_keyframes()) commit(false, false);
        return;
      }
      if (has_keyframes()) {
        const size_t keyframes = keyframe_count();
        uint64_t steps = 0;
        {
          std::lock_guard lock(map_mutex);
          steps = mapper->refinement_steps();
        }
        if (steps > 0) {
          // The refinement takes minutes after a long drive, and a launch that ends kills the node
          // (roslaunch: SIGTERM 15 s after SIGINT): every frame mapped is committed before it starts,
          // so such a kill costs the refinement only. Whoever stopped the node sees why it still runs.
          commit(false, false);
          log::info("refining the map: ", steps, " steps over ", keyframes,
                    " keyframes (every frame is committed)");
        }
        {
          // The node's queries get their turns between steps, as during mapping.
          std::unique_lock lock(map_mutex);
          mapper->refine(steps, [&](uint32_t) {
            lock.unlock();
            lock.lock();
          });
        }
        commit(true, false);
        log::info("map ", settings.out, ": ", mapper->total_gaussians(), " Gaussians, ",
                  mapper->keyframes().size(), " keyframes from ", next_frame.load(), " frames",
                  dropped_note());
      } else {
        log::warn("map ", settings.out, ": no keyframe arrived; nothing was mapped");
      }
    } catch (const std::exception& e) {
      {
        std::lock_guard lock(queue_mutex);
        error = e.what();
        failed = true;  // the tracker's thread stops too
      }
      queue_cv.notify_all();
      log::error("mapping stopped: ", e.what());
    }
  }
};

std::string set_process_defaults() {
  chungs::set_process_defaults();
  return allocator_description();
}

LiveMapper::LiveMapper(const Settings& s) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.settings = s;
  if (s.preset != "outdoor" && s.preset != "indoor")
    fail("preset must be outdoor or indoor, got '", s.preset, "'");
  apply_preset(m.config, s.preset, "");
  if (!s.config_yaml.empty()) m.config = config_from_yaml(s.config_yaml, "ROS parameters", m.config);
  m.config.mapper.device = s.device;
  m.config.mapper.validate();
  m.queue_bound = queue_bound(s, m.config.mapper);  // before the folder is made: a bad value leaves none
  resolve_device(m.config.mapper.device);
  m.mapper = std::make_unique<Mapper>(s.out, m.config, s.resume);
  // Keyframes at another size would train one map at two scales of detail, as with `run --resume`.
  if (const std::optional<double> had = other_resolution(m.mapper->resumed_state(), m.config.mapper.resolution))
    fail(s.out, ": the map was made at mapper.resolution ", *had, ", the settings give ", m.config.mapper.resolution,
         "; a resumed map keeps its resolution");
  // A live source has no end, so its map can always outgrow the budget: the memory for chunks in flight
  // is made resident now, as `run` does for a dataset that can (pipeline/run_pipeline.cpp), and the heap
  // keeps what it frees, so host memory stays level once the budget is full instead of rising each time
  // a queue reaches a new high.
  keep_heap_for_reuse(0);
  m.mapper->in_flight_blocks().make_resident();
  log::info("chunks in flight: ", m.mapper->in_flight_blocks().capacity_bytes() >> 20, " MB made resident");
  if (s.track) {
    // The tracker's own map is not kept in the folder: a resumed run could not continue its poses.
    if (s.resume) fail(s.out, ": resume continues maps made on the robot's poses only, not on the tracker's");
    m.tracker = std::make_unique<tracking::VisualTracker>();
    m.updates = std::make_unique<PoseUpdateApplier>(*m.mapper, m.config.mapper);
  }
  if (s.resume && m.mapper->resumed_state().is_object()) {
    m.next_frame = m.mapper->resumed_state().value("next_frame", uint64_t(0));
    m.carried_seconds = m.mapper->resumed_state().value("seconds", 0.0);
    if (!m.mapper->keyframes().empty()) m.last_keyframe = m.mapper->keyframes().back().pose;
  }
  m.worker = std::thread([&m] { m.run(); });
  if (m.tracker) m.tracking = std::thread([&m] { m.track_frames(); });
}

LiveMapper::~LiveMapper() {
  try {
    finish();
  } catch (const std::exception& e) {
    log::error("finishing the map: ", e.what());
  }
}

void LiveMapper::push(LiveFrame frame) {
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.queue_mutex);
    if (m.finishing) return;
    if (m.queue_bound > 0 && m.queue.size() >= m.queue_bound) {
      m.queue.pop_front();
      ++m.next_frame;  // the dropped frame keeps its index: held-out frames stay where they were
      if (m.dropped++ == 0)
        log::warn("the mapper is behind its intake: frames beyond the ", m.queue_bound,
                  " waiting are dropped, the oldest first (~max_queue; the status counts them)");
    }
    m.queue.push_back(std::move(frame));
  }
  // All: with the tracker's thread, the mapping thread waits on the same condition for tracked frames,
  // and a single wakeup that reached it would leave the frame untracked until the next one came.
  m.queue_cv.notify_all();
}

void LiveMapper::skip() {
  {
    std::lock_guard lock(impl_->queue_mutex);
    ++impl_->without_pose;
  }
  push(LiveFrame{});
}

std::optional<rosbag_io::Picture> LiveMapper::render_latest() {
  Impl& m = *impl_;
  std::lock_guard lock(m.map_mutex);
  if (m.mapper->keyframes().empty()) return std::nullopt;
  const KeyframeRecord& kf = m.mapper->keyframes().back();
  RenderOutput<float> r = m.mapper->render(kf.camera, kf.pose);
  Image8 rgb = to_u8(r.rgb);
  rosbag_io::Picture p;
  p.width = rgb.width();
  p.height = rgb.height();
  p.channels = rgb.channels();
  p.pixels = std::move(rgb.vec());
  return p;
}

std::vector<float> LiveMapper::centres(double radius) {
  Impl& m = *impl_;
  Eigen::Vector3d at;
  {
    std::lock_guard lock(m.map_mutex);
    if (m.mapper->keyframes().empty()) return {};
    at = m.mapper->keyframes().back().pose.t;
  }
  std::vector<float> out;
  std::error_code ec;
  if (!std::filesystem::exists(std::filesystem::path(m.settings.out) / "manifest.txt", ec)) return out;
  ChunkStore store(m.settings.out, reader_config());  // the committed checkpoint; never blocks the mapper
  for (ChunkId id : store.ids()) {
    if (far_level_with_near_twin(store, id)) continue;
    Eigen::Vector3d lo, hi;
    chunk_box(chunk_coord(id), store.chunk_size(), lo, hi);
    if ((at.cwiseMax(lo).cwiseMin(hi) - at).norm() > radius) continue;
    const GaussianBlock block = store.load(id);
    out.insert(out.end(), block.params.mean.begin(), block.params.mean.end());
  }
  return out;
}

std::vector<rosbag_io::Pose> LiveMapper::keyframe_poses() {
  Impl& m = *impl_;
  std::lock_guard lock(m.map_mutex);
  std::vector<rosbag_io::Pose> out;
  for (const auto& kf : m.mapper->keyframes()) out.push_back(to_pose(kf.pose));
  return out;
}

size_t LiveMapper::correct(const std::vector<std::pair<double, rosbag_io::Pose>>& poses) {
  Impl& m = *impl_;
  const MapperConfig& mc = m.config.mapper;
  std::lock_guard lock(m.map_mutex);
  const auto& kfs = m.mapper->keyframes();
  std::vector<std::pair<uint32_t, SE3>> moves;
  for (const auto& [stamp, pose] : poses) {
    // Keyframes are in stamp order; a correction names the stamp of the image it was made for.
    auto it = std::lower_bound(kfs.begin(), kfs.end(), stamp,
                               [](const KeyframeRecord& k, double t) { return k.stamp < t; });
    for (auto c : {it, it == kfs.begin() ? kfs.end() : std::prev(it)}) {
      if (c == kfs.end() || std::abs(c->stamp - stamp) > 1e-4) continue;
      const SE3 target = to_se3(pose);
      const SE3 change = c->pose.inverse() * target;
      if (change.t.norm() >= mc.pose_update_min_translation ||
          change.angle() * 180.0 / M_PI >= mc.pose_update_min_rotation_deg)
        moves.emplace_back(c->id, target);
      break;
    }
  }
  if (moves.empty()) return 0;
  // As bundle adjustment's updates in `diskchungs run`: no junction to refine, since an external
  // system does not say where its loop closed; training goes on as usual afterwards.
  const PoseCorrectionStats st = m.mapper->correct_poses(moves, {}, 0);
  m.mapper->checkpoint(m.state(false), false);
  m.corrected += moves.size();
  log::info("external correction: ", moves.size(), " keyframes moved, ", st.gaussians_moved, " Gaussians, ",
            st.chunks_touched, " chunks");
  return moves.size();
}

Status LiveMapper::status() {
  Impl& m = *impl_;
  Status s;
  {
    std::lock_guard lock(m.queue_mutex);
    s.queued = m.queue.size() + m.decided.size() + (m.being_tracked ? 1 : 0);
    s.dropped = m.dropped;
    s.without_pose = m.without_pose;
    s.error = m.error;
    s.frames = m.next_frame;
  }
  std::lock_guard lock(m.map_mutex);
  s.corrected = m.corrected;
  const Mapper& mp = *m.mapper;
  s.keyframes = mp.keyframes().size();
  s.iterations = mp.iterations();
  s.gaussians = mp.total_gaussians();
  s.resident = mp.resident_gaussians();
  s.budget = mp.budget();
  s.chunks = mp.chunk_count();
  s.io_wait_ms = mp.optimiser_io_wait_ms();
  s.least_steps_per_keyframe = m.least_steps ? int64_t(*m.least_steps) : -1;
  s.seconds = m.seconds();
  const double dt = std::chrono::duration<double>(Clock::now() - m.rate_at).count();
  if (dt >= 1.0) {
    m.steps_per_s = double(s.iterations - m.rate_iterations) / dt;
    m.rate_iterations = s.iterations;
    m.rate_at = Clock::now();
  }
  s.steps_per_s = m.steps_per_s;
  return s;
}

void LiveMapper::checkpoint() {
  Impl& m = *impl_;
  if (!m.has_keyframes()) fail(m.settings.out, ": nothing to commit yet (no keyframe has arrived)");
  m.commit(false, false);
}

uint64_t LiveMapper::export_ply(const std::string& file, const std::vector<double>& box) {
  Impl& m = *impl_;
  if (!box.empty() && box.size() != 6)
    fail("export box needs 6 numbers (x0 y0 z0 x1 y1 z1), got ", box.size());
  {
    // Readers never write into a map folder (the mapper owns it): the PLY goes elsewhere.
    namespace fs = std::filesystem;
    const fs::path map = fs::weakly_canonical(fs::absolute(m.settings.out));
    const fs::path target = fs::weakly_canonical(fs::absolute(file));
    if (std::mismatch(map.begin(), map.end(), target.begin(), target.end()).first == map.end())
      fail(file, ": the export must be written outside the map folder ", m.settings.out);
  }
  {
    std::lock_guard lock(m.queue_mutex);
    if (!m.finished) {
      // The export reads what is committed: commit the map as it is now first.
      std::lock_guard map_lock(m.map_mutex);
      if (!m.mapper->keyframes().empty()) m.mapper->checkpoint(m.state(false), false);
    }
  }
  ChunkStore store(m.settings.out, reader_config());
  PlySelection s;
  if (!box.empty()) {
    s.box_lo = Eigen::Vector3d(box[0], box[1], box[2]);
    s.box_hi = Eigen::Vector3d(box[3], box[4], box[5]);
  }
  return chungs::export_ply(store, file, s);
}

void LiveMapper::finish() {
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.queue_mutex);
    if (m.finished) return;
    m.finishing = true;
  }
  m.queue_cv.notify_all();
  if (m.tracking.joinable()) m.tracking.join();
  if (m.worker.joinable()) m.worker.join();
  std::lock_guard lock(m.queue_mutex);
  m.finished = true;
  if (!m.error.empty()) fail("mapping failed: ", m.error);
}

}  // namespace chungs::live
