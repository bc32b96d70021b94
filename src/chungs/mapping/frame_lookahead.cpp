#include "chungs/mapping/frame_lookahead.hpp"

#include <algorithm>
#include <chrono>
#include <thread>

#include "chungs/common/error.hpp"

namespace chungs {

FrameLookahead::FrameLookahead(FrameFeed& feed, size_t depth, Load load, SecondsUntil seconds_until)
    : feed_(feed), depth_(depth), load_(std::move(load)), until_(std::move(seconds_until)) {}

FrameLookahead::~FrameLookahead() {
  stop_ = true;
  for (auto& e : ahead_)
    if (e.frame.valid()) e.frame.wait();
}

void FrameLookahead::fill(size_t target) {
  while (!feed_done_ && ahead_.size() < target) {
    std::optional<FeedItem> item = feed_.next();
    if (!item) {
      feed_done_ = true;
      break;
    }
    Entry e{std::move(*item), {}};
    if (e.item.keyframe && e.item.pose) {
      const size_t i = e.item.frame;
      // std::async (not a fixed pool): at most `depth` loads run at once, and each takes tens of
      // milliseconds, so a thread per frame costs nothing measurable.
      e.frame = std::async(std::launch::async, [this, i] {
        // Sleeps in short slices so that a destructor (an error on the mapper's side) need not
        // wait for a frame due seconds from now.
        for (double s; until_ && !stop_ && (s = until_(i)) > 0;)
          std::this_thread::sleep_for(std::chrono::duration<double>(std::min(s, 0.02)));
        if (stop_) fail("frame ", i, ": not loaded (the run stopped)");
        return load_(i);
      });
    }
    ahead_.push_back(std::move(e));
  }
}

std::optional<FrameLookahead::Entry> FrameLookahead::next() {
  fill(std::max<size_t>(depth_, 1));
  if (ahead_.empty()) return std::nullopt;
  Entry e = std::move(ahead_.front());
  ahead_.pop_front();
  fill(depth_);  // the next loads start before the caller works on this one
  return e;
}

bool FrameLookahead::ready(const Entry& e) {
  return !e.frame.valid() || e.frame.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

}  // namespace chungs
