#include "chungs/residency/checkpoint_writer.hpp"

#include <algorithm>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"

namespace chungs {

CheckpointWriter::CheckpointWriter(ChunkStore& store, int threads) : store_(store) {
  store_.begin_snapshot();
  for (int t = 0; t < std::max(threads, 1); ++t) threads_.emplace_back([this] { run(); });
}

CheckpointWriter::~CheckpointWriter() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  work_cv_.notify_all();
  for (auto& t : threads_) t.join();
  if (store_.snapshot_pending()) {
    log::warn(store_.folder().string(), ": a checkpoint written behind was not finished; the previous one stands");
    store_.abandon_snapshot();
  }
}

void CheckpointWriter::put(ChunkId id, Block content) {
  std::lock_guard lock(mutex_);
  if (closed_) fail("checkpoint writer: ", chunk_name(id), " handed over after close()");
  queued_gaussians_ += content->size();
  queue_.emplace_back(id, std::move(content));
  work_cv_.notify_one();
}

size_t CheckpointWriter::queued_gaussians() const {
  std::lock_guard lock(mutex_);
  return queued_gaussians_;
}

void CheckpointWriter::wait_below(size_t gaussians) {
  std::unique_lock lock(mutex_);
  done_cv_.wait(lock, [&] { return queued_gaussians_ < gaussians || queued_gaussians_ == 0 || finished_; });
}

void CheckpointWriter::close(std::function<void()> before_commit, std::function<void()> after_commit) {
  std::lock_guard lock(mutex_);
  before_commit_ = std::move(before_commit);
  after_commit_ = std::move(after_commit);
  closed_ = true;
  work_cv_.notify_all();
}

bool CheckpointWriter::finished() const {
  std::lock_guard lock(mutex_);
  return finished_;
}

void CheckpointWriter::rethrow() const {
  std::lock_guard lock(mutex_);
  if (error_) std::rethrow_exception(error_);
}

void CheckpointWriter::wait() {
  std::unique_lock lock(mutex_);
  if (!closed_) fail("checkpoint writer: wait() before close()");
  done_cv_.wait(lock, [&] { return finished_; });
  if (error_) std::rethrow_exception(error_);
}

void CheckpointWriter::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    work_cv_.wait(lock, [&] { return stop_ || leaving_ || !queue_.empty() || (closed_ && busy_ == 0); });
    if (stop_ || leaving_) return;
    if (queue_.empty()) {  // closed, nothing left in flight: this thread commits
      commit_now(lock);
      return;
    }
    auto [id, block] = std::move(queue_.front());
    queue_.pop_front();
    ++busy_;
    lock.unlock();
    std::exception_ptr failed;
    try {
      store_.save_arrays_to_snapshot(id, block->arrays());
    } catch (...) {
      failed = std::current_exception();
    }
    lock.lock();
    --busy_;
    queued_gaussians_ -= block->size();
    done_cv_.notify_all();  // wait_below()
    if (failed && !error_) {
      error_ = failed;
      finished_ = leaving_ = true;
      store_.abandon_snapshot();
      queue_.clear();
      queued_gaussians_ = 0;
      done_cv_.notify_all();
      work_cv_.notify_all();
      return;
    }
    if (closed_ && queue_.empty() && busy_ == 0) work_cv_.notify_all();
  }
}

void CheckpointWriter::commit_now(std::unique_lock<std::mutex>& lock) {
  leaving_ = true;  // the other threads leave; this one reports when done
  work_cv_.notify_all();
  auto before = std::move(before_commit_), after = std::move(after_commit_);
  lock.unlock();
  std::exception_ptr failed;
  try {
    if (before) before();
    store_.commit_snapshot();
  } catch (...) {
    failed = std::current_exception();
    store_.abandon_snapshot();
  }
  if (!failed) try {
      if (after) after();
    } catch (...) {
      failed = std::current_exception();
    }
  lock.lock();
  error_ = failed;
  finished_ = true;
  done_cv_.notify_all();
}

}  // namespace chungs
