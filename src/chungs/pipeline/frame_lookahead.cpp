#include "chungs/pipeline/frame_lookahead.hpp"

#include <algorithm>
#include <chrono>
#include <thread>

#include "chungs/common/error.hpp"

namespace chungs {

FrameLookahead::FrameLookahead(FrameFeed& feed, size_t depth, Load load, SecondsUntil seconds_until, Seen seen)
    : feed_(feed), depth_(depth), load_(std::move(load)), until_(std::move(seconds_until)), seen_(std::move(seen)) {
  for (size_t k = 0; k <= depth_; ++k) workers_.emplace_back([this] { work(); });
}

FrameLookahead::~FrameLookahead() {
  stop_ = true;
  {
    std::lock_guard lock(mutex_);
    tasks_.clear();  // their futures report a broken promise, which nobody reads any more
  }
  wake_.notify_all();
  for (auto& w : workers_) w.join();
}

void FrameLookahead::work() {
  for (;;) {
    std::packaged_task<MappingFrame()> task;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || !tasks_.empty(); });
      if (tasks_.empty()) return;
      task = std::move(tasks_.front());
      tasks_.pop_front();
    }
    task();  // a load's exception is stored in its future
  }
}

void FrameLookahead::fill(size_t target, bool wait_for_one) {
  while (!feed_done_ && ahead_.size() < target) {
    // A live feed (the tracker) is waited for only for the item the caller needs now; beyond it,
    // only what it already has is pulled, so the loads of those keyframes start early.
    if (!(wait_for_one && ahead_.empty()) && !feed_.ready()) break;
    std::optional<FeedItem> item = feed_.next();
    if (!item) {
      feed_done_ = true;
      break;
    }
    Entry e{std::move(*item), {}};
    if (seen_) seen_(e.item);
    if (e.item.keyframe && e.item.pose) {
      const size_t i = e.item.frame;
      std::packaged_task<MappingFrame()> task([this, i] {
        // Sleeps in short slices so that a destructor (an error on the mapper's side) need not
        // wait for a frame due seconds from now.
        for (double s; until_ && !stop_ && (s = until_(i)) > 0;)
          std::this_thread::sleep_for(std::chrono::duration<double>(std::min(s, 0.02)));
        if (stop_) fail("frame ", i, ": not loaded (the run stopped)");
        return load_(i);
      });
      e.frame = task.get_future();
      {
        std::lock_guard lock(mutex_);
        tasks_.push_back(std::move(task));
      }
      wake_.notify_one();
    }
    ahead_.push_back(std::move(e));
  }
}

std::optional<FrameLookahead::Entry> FrameLookahead::next() {
  fill(std::max<size_t>(depth_, 1), true);
  if (ahead_.empty()) return std::nullopt;
  Entry e = std::move(ahead_.front());
  ahead_.pop_front();
  fill(depth_, false);  // the next loads start before the caller works on this one
  return e;
}

bool FrameLookahead::ready(const Entry& e) {
  return !e.frame.valid() || e.frame.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

bool FrameLookahead::later_keyframe_ready() const {
  if (!until_) return false;
  // Loaded, not only arrived: loads run side by side from arrival, so a later frame that has only
  // arrived says nothing about the mapper, one already loaded says it fell behind.
  for (const Entry& e : ahead_)
    if (e.has_frame() && until_(e.item.frame) <= 0 && ready(e)) return true;
  return false;
}

}  // namespace chungs
