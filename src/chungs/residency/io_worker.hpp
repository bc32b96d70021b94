// IoWorker: the chunk I/O thread between Residency and the ChunkStore.
//
// Write-behind: an evicted modified chunk is handed over as an immutable block that the worker
// owns until it is on disk; its pool slots can be reused at once. Until the write has finished,
// any load of that chunk is served from the queued block, never from the stale file. Writes run on
// `threads` threads: a refinement that mixes places evicts a dirty chunk for nearly every load, and
// one thread writing them (~0.5 ms each on the GPU machine) held the optimiser up. Two writes of
// one chunk never overlap, so the newest content is the one kept. A written chunk is left to the
// page cache (ChunkStore::Writeback::Leave): the next commit flushes it, if no later version replaced it.
// Prefetch: chunks predicted to be needed next are read into host memory ahead of time, on every
// thread: reads come before writes, unless the write queue is half full, except on the first thread,
// which always reads first. In a refinement under a small budget the queue stays half full, and
// reads that waited behind every thread's writes left 75 % of the loads to wait (GPU, 2 km street
// under 300 k, bench/README.md, issue 19).
// take() hands a chunk's current content to the caller from the first place that has it:
// the write-behind queue, the prefetched blocks, a read in flight (waits for it), or the disk.
//
// Every block in flight lives in `blocks` (host_block_pool.hpp); a read ahead for which it has no
// room waits for the next prediction.
//
// With background = false there is no thread: writes happen inside write_behind() and take()
// reads synchronously (deterministic, for tests and single-threaded tools).
#pragma once
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "chungs/residency/host_block_pool.hpp"
#include "chungs/store/chunk_store.hpp"

namespace chungs {

class IoWorker {
 public:
  using Block = std::shared_ptr<const HostBlock>;
  enum class Source { WriteBehind, Prefetched, InFlight, Disk, Absent };

  IoWorker(ChunkStore& store, HostBlockPool& blocks, bool background, size_t prefetch_max_gaussians,
           size_t write_behind_max_gaussians, int threads = 1);
  ~IoWorker();  // finishes queued writes (errors are logged), then stops the threads
  IoWorker(const IoWorker&) = delete;
  IoWorker& operator=(const IoWorker&) = delete;

  // Queues the chunk's new content (an empty block removes the chunk). Blocks while the queue
  // holds more than the write-behind limit (counted as a wait). Rethrows a failed background write.
  void write_behind(ChunkId id, Block data);
  // Replaces the prediction list: chunks (with their Gaussian counts) to read ahead, first needed
  // first. Reads it names are kept when the read-ahead limit is reached; the others are dropped.
  void prefetch(const std::vector<std::pair<ChunkId, uint64_t>>& chunks);
  // The chunk's current content; an absent chunk gives an empty block. Never stale (see above).
  Block take(ChunkId id, Source* source = nullptr);
  // take() of several chunks under one acquisition of the lock (the I/O threads hold it often:
  // a refinement step under a small budget takes ~60 chunks); their contents and sources in order.
  std::vector<Block> take_many(std::span<const ChunkId> ids, std::vector<Source>& sources);
  // Waits until every queued write is on disk, first retrying a write that failed earlier;
  // throws if a write fails. A failed write keeps its block queued and served to loads, and
  // write_behind() refuses new blocks (throws) until a drain() has succeeded.
  void drain();

  size_t queued_write_gaussians() const;
  size_t staged_gaussians() const;

 private:
  struct Pending {
    Block data;
    bool queued = false;  // a job for it is in write_queue_
  };
  void run(int index);  // every thread: urgent writes (not the first), then reads ahead, then writes
  // The first queued chunk that no thread is writing now (a chunk queued again while its earlier
  // content is being written waits for that write); end() when there is none.
  std::deque<ChunkId>::iterator next_writable();
  bool write_one(std::unique_lock<std::mutex>& lock);
  bool prefetch_one(std::unique_lock<std::mutex>& lock);
  void write_now(ChunkId id, const Block& data);
  void rethrow_locked();

  ChunkStore& store_;
  HostBlockPool& blocks_;
  IoCounters& counters_;
  const bool background_;
  const size_t prefetch_max_, write_behind_max_;

  mutable std::mutex mutex_;
  std::condition_variable work_cv_, done_cv_;
  std::unordered_map<ChunkId, Pending> pending_;  // written-behind, not yet on disk
  std::deque<ChunkId> write_queue_;
  size_t pending_gaussians_ = 0;
  std::unordered_set<ChunkId> writing_;           // being written now, by some thread
  std::deque<std::pair<ChunkId, uint64_t>> prefetch_queue_;
  std::unordered_map<ChunkId, Block> staged_;     // prefetched, not yet taken
  std::deque<ChunkId> staged_order_;              // oldest first, for dropping when over the limit
  std::unordered_set<ChunkId> wanted_;            // named by the latest prefetch() (kept staged)
  size_t staged_gaussians_ = 0;
  std::unordered_set<ChunkId> reading_;           // reads ahead in flight
  size_t reading_gaussians_ = 0;                  // their counts (the read-ahead limit covers them)
  std::exception_ptr error_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace chungs
