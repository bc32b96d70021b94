// CheckpointWriter: one checkpoint written behind the optimiser (Residency::begin_checkpoint).
//
// The caller hands over each modified chunk's content as of the checkpoint's moment; writer
// threads save them into the store's pending snapshot (ChunkStore::begin_snapshot) while the
// caller goes on training. Once close() has been called and the last block is saved, a writer
// runs `before_commit` (e.g. the keyframe store's barrier and the keyframe list), commits the
// snapshot and runs `after_commit`. Any failure abandons the snapshot, so the previous commit
// stands, and is rethrown to the caller by rethrow() or wait().
#pragma once
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "chungs/residency/host_block_pool.hpp"
#include "chungs/store/chunk_store.hpp"

namespace chungs {

class CheckpointWriter {
 public:
  using Block = std::shared_ptr<const HostBlock>;

  // Begins the store's snapshot; `threads` writers (at least 1).
  CheckpointWriter(ChunkStore& store, int threads);
  ~CheckpointWriter();  // an unfinished checkpoint is abandoned (the last commit stands)
  CheckpointWriter(const CheckpointWriter&) = delete;
  CheckpointWriter& operator=(const CheckpointWriter&) = delete;

  void put(ChunkId id, Block content);  // an empty block: the chunk is not in the checkpoint
  size_t queued_gaussians() const;      // handed over, not yet saved (host memory in use)
  void wait_below(size_t gaussians);    // until fewer are queued (or the checkpoint failed)
  // No more blocks: commit once the queued ones are saved.
  void close(std::function<void()> before_commit, std::function<void()> after_commit);
  bool finished() const;  // committed, or failed
  void rethrow() const;   // the failure, if any
  void wait();            // until finished; rethrows a failure

 private:
  void run();
  void commit_now(std::unique_lock<std::mutex>& lock);

  ChunkStore& store_;
  mutable std::mutex mutex_;
  std::condition_variable work_cv_, done_cv_;
  std::deque<std::pair<ChunkId, Block>> queue_;
  size_t queued_gaussians_ = 0;
  int busy_ = 0;
  bool closed_ = false, finished_ = false, stop_ = false;
  bool leaving_ = false;  // committing or failed: writer threads exit
  std::function<void()> before_commit_, after_commit_;
  std::exception_ptr error_;
  std::vector<std::thread> threads_;
};

}  // namespace chungs
