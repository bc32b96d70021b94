// Frames read ahead of the mapper: order kept, loads started before they are asked for (and not
// before the frame arrives under real-time pacing), nothing pulled ahead of a live feed, load
// errors reaching the caller, a stop that does not wait for frames due later, and loads kept on a
// fixed set of threads however long the run.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/pipeline/frame_lookahead.hpp"

namespace chungs {
namespace {

using namespace std::chrono_literals;

// n frames; every odd frame is a keyframe with a pose, even frames are not keyframes.
class CountingFeed : public FrameFeed {
 public:
  explicit CountingFeed(size_t n) : n_(n) {}
  std::optional<FeedItem> next() override {
    if (pulled_ >= n_) return std::nullopt;
    FeedItem it;
    it.frame = pulled_++;
    it.keyframe = it.frame % 2 == 1;
    if (it.keyframe) it.pose = SE3();
    return it;
  }
  std::vector<std::optional<SE3>> final_poses() override { return {}; }
  nlohmann::json report() const override { return {}; }
  size_t pulled() const { return pulled_; }

 private:
  size_t n_, pulled_ = 0;
};

MappingFrame frame_marked(size_t i) {
  MappingFrame m;
  m.frame.index = i;
  return m;
}

TEST(FrameLookahead, HandsOutEveryItemInOrderWithItsOwnFrame) {
  CountingFeed feed(9);
  FrameLookahead ahead(feed, 3, frame_marked);
  size_t expected = 0;
  while (auto e = ahead.next()) {
    EXPECT_EQ(e->item.frame, expected);
    EXPECT_EQ(e->has_frame(), expected % 2 == 1);
    if (e->has_frame()) {
      EXPECT_EQ(e->frame.get().frame.index, expected);
    }
    ++expected;
  }
  EXPECT_EQ(expected, 9u);
}

TEST(FrameLookahead, LoadsTheNextKeyframesBeforeTheyAreAskedFor) {
  CountingFeed feed(20);
  std::mutex mu;
  std::set<size_t> loaded;
  FrameLookahead ahead(feed, 4, [&](size_t i) {
    std::lock_guard lock(mu);
    loaded.insert(i);
    return frame_marked(i);
  });
  auto first = ahead.next();
  ASSERT_TRUE(first);
  EXPECT_EQ(feed.pulled(), 5u);  // the item handed out and four ahead
  // Frames 1 and 3 are keyframes among items 1..4: both load without being asked for.
  for (int t = 0; t < 200; ++t) {
    {
      std::lock_guard lock(mu);
      if (loaded.count(1) && loaded.count(3)) break;
    }
    std::this_thread::sleep_for(5ms);
  }
  std::lock_guard lock(mu);
  EXPECT_EQ(loaded, (std::set<size_t>{1, 3}));
}

TEST(FrameLookahead, PullsNothingAheadOfALiveFeedAtDepthZero) {
  CountingFeed feed(6);
  FrameLookahead ahead(feed, 0, frame_marked);
  for (size_t k = 1; k <= 6; ++k) {
    auto e = ahead.next();
    ASSERT_TRUE(e);
    EXPECT_EQ(feed.pulled(), k);
  }
  EXPECT_FALSE(ahead.next());
}

TEST(FrameLookahead, ALoadStartsOnlyOnceItsFrameHasArrived) {
  CountingFeed feed(4);
  const auto t0 = std::chrono::steady_clock::now();
  auto now = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  std::atomic<double> loaded_at{-1};
  // Frame i arrives at 0.1 s * i.
  FrameLookahead ahead(
      feed, 3,
      [&](size_t i) {
        if (i == 3) loaded_at = now();
        return frame_marked(i);
      },
      [&](size_t i) { return 0.1 * double(i) - now(); });
  ahead.next();            // frame 0
  auto e1 = ahead.next();  // frame 1, arriving at 0.1 s
  ASSERT_TRUE(e1 && e1->has_frame());
  e1->frame.get();
  EXPECT_GE(now(), 0.1);
  ahead.next();            // frame 2
  auto e3 = ahead.next();  // frame 3 is due at 0.3 s
  ASSERT_TRUE(e3 && e3->has_frame());
  e3->frame.get();
  EXPECT_GE(loaded_at.load(), 0.3);
}

TEST(FrameLookahead, AKeyframeIsStaleOnlyOnceALaterOneHasArrivedAndLoaded) {
  CountingFeed feed(8);  // keyframes 1, 3, 5, 7
  std::atomic<bool> slow{true};
  std::atomic<double> clock{0};
  // Frame i arrives at i seconds of a clock the test moves; frame 3's load waits while `slow`.
  FrameLookahead ahead(
      feed, 4,
      [&](size_t i) {
        while (i == 3 && slow) std::this_thread::sleep_for(1ms);
        return frame_marked(i);
      },
      [&](size_t i) { return double(i) - clock.load(); });
  EXPECT_FALSE(ahead.later_keyframe_ready());
  ahead.next();            // frame 0; 1..4 queued
  auto e1 = ahead.next();  // frame 1; 2..5 queued
  ASSERT_TRUE(e1 && e1->has_frame());
  EXPECT_FALSE(ahead.later_keyframe_ready());  // frame 3 has not arrived
  clock = 3.5;                                 // frame 3 arrived, its load is still running
  std::this_thread::sleep_for(20ms);
  EXPECT_FALSE(ahead.later_keyframe_ready());
  slow = false;  // loaded: the mapper, still on frame 1, is behind
  for (int k = 0; k < 200 && !ahead.later_keyframe_ready(); ++k) std::this_thread::sleep_for(5ms);
  EXPECT_TRUE(ahead.later_keyframe_ready());
  // Without arrival times (fixed pacing) nothing is ever stale.
  CountingFeed other(4);
  FrameLookahead fixed(other, 2, frame_marked);
  fixed.next();
  fixed.next();
  std::this_thread::sleep_for(10ms);
  EXPECT_FALSE(fixed.later_keyframe_ready());
}

TEST(FrameLookahead, ALoadErrorReachesTheCallerForItsFrame) {
  CountingFeed feed(4);
  FrameLookahead ahead(feed, 2, [](size_t i) -> MappingFrame {
    if (i == 3) fail("frame ", i, ": unreadable");
    return frame_marked(i);
  });
  ahead.next();
  auto e1 = ahead.next();
  EXPECT_NO_THROW(e1->frame.get());
  ahead.next();
  auto e3 = ahead.next();
  EXPECT_THROW(e3->frame.get(), Error);
}

TEST(FrameLookahead, StoppingDoesNotWaitForFramesDueLater) {
  const auto t0 = std::chrono::steady_clock::now();
  {
    CountingFeed feed(10);
    FrameLookahead ahead(feed, 4, frame_marked, [](size_t) { return 60.0; });  // every frame a minute away
    auto e = ahead.next();  // frame 0 (no keyframe); keyframes 1 and 3 wait ahead for their arrival
    ASSERT_TRUE(e);
    EXPECT_FALSE(e->has_frame());
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
}

// Counts the threads that ever ran a load: a thread_local is constructed once per thread, even when
// a new thread reuses an ended one's id.
std::atomic<int> g_load_threads{0};
struct LoadThreadMark {
  LoadThreadMark() { ++g_load_threads; }
};

TEST(FrameLookahead, LoadsRunOnAFixedSetOfThreadsHoweverManyFrames) {
  g_load_threads = 0;
  CountingFeed feed(200);
  FrameLookahead ahead(feed, 2, [&](size_t i) {
    thread_local LoadThreadMark mark;
    (void)mark;
    return frame_marked(i);
  });
  size_t loads = 0;
  while (auto e = ahead.next())
    if (e->has_frame()) {
      e->frame.get();
      ++loads;
    }
  EXPECT_EQ(loads, 100u);
  EXPECT_GE(g_load_threads.load(), 1);
  EXPECT_LE(g_load_threads.load(), 3);  // depth + 1, not one per frame
}

}  // namespace
}  // namespace chungs

namespace chungs {
namespace {

// A live source: items become available only when released (like the tracker finishing a frame).
class GatedFeed : public CountingFeed {
 public:
  using CountingFeed::CountingFeed;
  bool ready() const override { return open_; }
  std::atomic<bool> open_{false};
};

TEST(FrameLookahead, SaysWhetherTheNextItemWouldWaitForALiveFeed) {
  GatedFeed feed(2);
  FrameLookahead ahead(feed, 0, frame_marked);
  EXPECT_FALSE(ahead.next_ready());  // the tracker has nothing yet: the mapper may train meanwhile
  feed.open_ = true;
  EXPECT_TRUE(ahead.next_ready());
  ASSERT_TRUE(ahead.next());
  feed.open_ = false;
  EXPECT_FALSE(ahead.next_ready());
  feed.open_ = true;
  ASSERT_TRUE(ahead.next());
  EXPECT_FALSE(ahead.next());
  feed.open_ = false;
  EXPECT_TRUE(ahead.next_ready());  // after the end the answer (none) needs no wait
}

}  // namespace
}  // namespace chungs

namespace chungs {
namespace {

TEST(FrameLookahead, PullsAheadOfALiveFeedOnlyWhatItAlreadyHas) {
  GatedFeed feed(8);
  FrameLookahead ahead(feed, 3, frame_marked);
  ASSERT_TRUE(ahead.next());  // the item needed now is waited for ...
  EXPECT_EQ(feed.pulled(), 1u);  // ... but none beyond it while the feed has nothing ready
  feed.open_ = true;
  ASSERT_TRUE(ahead.next());
  EXPECT_EQ(feed.pulled(), 5u);  // ready: the one handed out and three ahead
  feed.open_ = false;
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(ahead.next());  // the three pulled ahead, no more pulls
  EXPECT_EQ(feed.pulled(), 5u);
}

}  // namespace
}  // namespace chungs
