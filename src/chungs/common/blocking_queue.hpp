// BlockingQueue: hands items from one producer thread to one consumer thread, in order. The
// producer ends the stream with close(), or with fail() to pass its exception to the consumer,
// which then sees it rethrown by pop() once the items queued before it are taken. With a capacity,
// push() waits while that many items are queued; a consumer that stops early calls close(), which
// releases a waiting producer (push() then drops the item and returns false).
#pragma once
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>

namespace chungs {

template <class T>
class BlockingQueue {
 public:
  explicit BlockingQueue(size_t capacity = 0) : capacity_(capacity) {}
  bool push(T item) {
    {
      std::unique_lock lock(mutex_);
      room_.wait(lock, [&] { return capacity_ == 0 || items_.size() < capacity_ || closed_; });
      if (closed_) return false;
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
    return true;
  }
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
  }
  void fail(std::exception_ptr error) {
    {
      std::lock_guard lock(mutex_);
      error_ = error;
      closed_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
  }
  // The next item; none once the queue is closed and drained. Rethrows the producer's failure.
  std::optional<T> pop() {
    std::unique_lock lock(mutex_);
    ready_.wait(lock, [&] { return !items_.empty() || closed_; });
    if (!items_.empty()) {
      T item = std::move(items_.front());
      items_.pop_front();
      lock.unlock();
      room_.notify_one();
      return item;
    }
    if (error_) std::rethrow_exception(error_);
    return std::nullopt;
  }
  // Whether pop() would return at once (an item, the end or the producer's failure).
  bool ready() const {
    std::lock_guard lock(mutex_);
    return !items_.empty() || closed_;
  }
  size_t size() const {
    std::lock_guard lock(mutex_);
    return items_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable ready_, room_;
  std::deque<T> items_;
  size_t capacity_;
  bool closed_ = false;
  std::exception_ptr error_;
};

}  // namespace chungs
