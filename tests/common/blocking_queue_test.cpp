// BlockingQueue with a capacity: the producer waits for room; a consumer that stops releases it.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "chungs/common/blocking_queue.hpp"
#include "chungs/common/error.hpp"

namespace chungs {
namespace {

TEST(BlockingQueue, AProducerWaitsForRoomAndItemsArriveInOrder) {
  BlockingQueue<int> q(2);
  std::atomic<int> pushed{0};
  std::thread producer([&] {
    for (int i = 0; i < 50; ++i) {
      ASSERT_TRUE(q.push(i));
      ++pushed;
    }
    q.close();
  });
  // The producer cannot run more than the capacity ahead of the consumer.
  while (pushed < 2) std::this_thread::yield();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(pushed.load(), 2);
  EXPECT_LE(q.size(), 2u);
  for (int i = 0; i < 50; ++i) {
    const auto v = q.pop();
    ASSERT_TRUE(v);
    EXPECT_EQ(*v, i);
    EXPECT_LE(q.size(), 2u);
  }
  EXPECT_FALSE(q.pop());
  producer.join();
}

TEST(BlockingQueue, ClosingReleasesAWaitingProducerAndFailuresReachTheConsumer) {
  BlockingQueue<int> q(1);
  ASSERT_TRUE(q.push(1));
  std::atomic<bool> returned{false}, result{true};
  std::thread producer([&] {
    result = q.push(2);  // waits: the queue is full
    returned = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(returned.load());
  q.close();
  producer.join();
  EXPECT_FALSE(result.load()) << "the item is dropped once the consumer stopped";

  BlockingQueue<int> f;
  f.push(7);
  f.fail(std::make_exception_ptr(Error("frame 3 could not be read")));
  EXPECT_EQ(f.pop(), 7);
  EXPECT_THROW(f.pop(), Error);
}

}  // namespace
}  // namespace chungs
