// Frames ahead of the mapper: items are pulled from the feed a few frames early and each keyframe's
// images and depth are loaded (decoded or rendered, stereo-matched) by a small fixed set of worker
// threads, so that this work overlaps the optimiser instead of stopping it. Under real-time pacing
// a frame's load starts no earlier than the moment the frame arrives: a camera cannot deliver it
// sooner. From a live feed (the tracker) only the items it already has are pulled ahead. The workers live as long as the lookahead: a thread per frame would leave per-thread
// state of the libraries it calls behind at every frame (OpenCV's thread-local buffers are kept
// after the thread ends: ~650 bytes a frame, without bound over a long drive).
#pragma once
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "chungs/pipeline/frame_feed.hpp"
#include "chungs/pipeline/frame_source.hpp"

namespace chungs {

class FrameLookahead {
 public:
  using Load = std::function<MappingFrame(size_t frame)>;
  using SecondsUntil = std::function<double(size_t frame)>;  // until the frame arrives (<= 0: it has)
  // Told of each item as it is pulled from the feed, in order, on the caller's thread, before its load
  // is queued: a load may then count on every earlier item being known (the multiview depth's
  // earlier keyframes).
  using Seen = std::function<void(const FeedItem& item)>;

  struct Entry {
    FeedItem item;
    std::future<MappingFrame> frame;  // valid only for a keyframe with a pose
    bool has_frame() const { return frame.valid(); }
  };

  // depth: items pulled from the feed beyond the one handed out (0: none; the handed-out keyframe
  // still loads while the caller steps); from a feed that is not ready() they are not waited for.
  // seconds_until may be empty (every frame is available at once).
  FrameLookahead(FrameFeed& feed, size_t depth, Load load, SecondsUntil seconds_until = {}, Seen seen = {});
  // Stops waiting for arrivals, waits for loads still running; their results (and errors) are
  // dropped, loads not yet started are not run.
  ~FrameLookahead();
  FrameLookahead(const FrameLookahead&) = delete;
  FrameLookahead& operator=(const FrameLookahead&) = delete;

  // The next item, after topping the lookahead up; none after the feed's last item.
  std::optional<Entry> next();
  // Whether next() would return without waiting for the feed (for a live source: the tracker).
  bool next_ready() const { return !ahead_.empty() || feed_done_ || feed_.ready(); }
  // True when entry's frame is loaded (or its load failed): get() will not block.
  static bool ready(const Entry& e);
  // Real-time pacing: true when a keyframe behind the last one handed out has already arrived and
  // been loaded, so that one is stale (the mapper fell behind the intake). False without arrival times.
  bool later_keyframe_ready() const;

 private:
  void fill(size_t target, bool wait_for_one);
  void work();
  FrameFeed& feed_;
  size_t depth_;
  Load load_;
  SecondsUntil until_;
  Seen seen_;
  std::atomic<bool> stop_{false};
  std::deque<Entry> ahead_;
  bool feed_done_ = false;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::packaged_task<MappingFrame()>> tasks_;
  std::vector<std::thread> workers_;  // depth + 1: the handed-out keyframe loads beside `depth` ahead
};

}  // namespace chungs
