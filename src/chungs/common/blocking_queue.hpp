// BlockingQueue: hands items from one producer thread to one consumer thread, in order. The
// producer ends the stream with close(), or with fail() to pass its exception to the consumer,
// which then sees it rethrown by pop() once the items queued before it are taken.
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
  void push(T item) {
    {
      std::lock_guard lock(mutex_);
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
  }
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
  }
  void fail(std::exception_ptr error) {
    {
      std::lock_guard lock(mutex_);
      error_ = error;
      closed_ = true;
    }
    ready_.notify_all();
  }
  // The next item; none once the queue is closed and drained. Rethrows the producer's failure.
  std::optional<T> pop() {
    std::unique_lock lock(mutex_);
    ready_.wait(lock, [&] { return !items_.empty() || closed_; });
    if (!items_.empty()) {
      T item = std::move(items_.front());
      items_.pop_front();
      return item;
    }
    if (error_) std::rethrow_exception(error_);
    return std::nullopt;
  }
  size_t size() const {
    std::lock_guard lock(mutex_);
    return items_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<T> items_;
  bool closed_ = false;
  std::exception_ptr error_;
};

}  // namespace chungs
