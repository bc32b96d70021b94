// Counters of chunk and keyframe I/O: what was read and written, how long it took, and how often
// the caller (the optimiser thread) had to wait for the disk. Counters are atomic so the
// background I/O thread and the caller update them concurrently; snapshot() gives plain numbers.
#pragma once
#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

namespace chungs {

struct IoStats {
  uint64_t loads = 0, saves = 0, removes = 0;  // files read / written / deleted
  uint64_t bytes_read = 0, bytes_written = 0;
  double load_ms = 0, save_ms = 0;  // summed over all loads / saves (any thread)
  // Residency: where chunks entering the pool came from, and how often the caller blocked.
  uint64_t pool_loads = 0;         // chunks scattered into the pool
  uint64_t prefetch_hits = 0;      // ... already read by the background thread
  uint64_t write_behind_hits = 0;  // ... still queued for writing (served from memory)
  uint64_t sync_loads = 0;         // ... read on the caller's thread (a wait)
  uint64_t waits = 0;              // sync loads + waits for an in-flight read or a full queue
  double wait_ms = 0;
  // Of those, waits for a full write-behind queue (evictions faster than the disk takes them).
  uint64_t write_waits = 0;
  double write_wait_ms = 0;
  uint64_t evictions_clean = 0, evictions_dirty = 0;
  // The optimiser thread's own copies between the pool and host memory: evicted modified chunks
  // gathered out of it (not the checkpoint's copies, which count in checkpoint_ms), and chunks
  // scattered into it once read. Not waits for the disk, but the same thread's time.
  double evict_copy_ms = 0, upload_ms = 0;
  // All of the optimiser thread's time evicting (copies and queueing the writes) and making chunks
  // resident (waits, copies, bookkeeping), the copies and waits above included.
  double evicting_ms = 0, loading_ms = 0;
  double take_ms = 0;  // of loading_ms: taking the chunks' contents from the I/O threads (waits included)
  double take_lock_ms = 0;  // of take_ms: waiting for the I/O threads' lock
  // Why reading ahead paused until the next prediction: every chunk read ahead is still wanted and
  // they fill the read-ahead, or the host memory for chunks in flight was taken (by queued writes).
  uint64_t read_ahead_full = 0, read_ahead_no_room = 0;
  uint64_t reader_writes = 0;  // writes made before reads ahead because the write queue was half full
  // Durability: saves are not flushed one by one; each commit() flushes the files written since
  // the previous one, then the folder, then writes the manifest (one barrier per checkpoint).
  uint64_t barriers = 0, synced_files = 0;
  double barrier_ms = 0;  // flushing files and folder, manifest write included
  // Checkpoints (Residency::flush): the caller blocks while dirty chunks are gathered, queued
  // writes finish and the barrier runs.
  uint64_t checkpoints = 0;
  double checkpoint_ms = 0;
  // Of those, written behind the caller (Residency::begin_checkpoint): the caller blocks only to
  // copy chunks out (counted in checkpoint_ms); from the checkpoint's moment to its commit took
  // behind_ms on the writer threads.
  uint64_t checkpoints_behind = 0;
  double checkpoint_behind_ms = 0;
  // Of checkpoint_ms, inside the checkpoints the caller waits for (Residency::flush, the final one):
  // gathering dirty chunks out of the pool, and the commit (barrier and manifest); the rest is
  // writing the files and waiting for queued writes.
  double flush_gather_ms = 0, flush_commit_ms = 0;

  double mean_load_ms() const { return loads ? load_ms / double(loads) : 0; }
  double mean_save_ms() const { return saves ? save_ms / double(saves) : 0; }
  // Fraction of chunks entering the pool for which the caller waited on the disk.
  double wait_fraction() const { return pool_loads ? double(sync_loads) / double(pool_loads) : 0; }
  // Time the optimiser thread was blocked by chunk I/O: loads it waited for plus checkpoints.
  double optimiser_wait_ms() const { return wait_ms + checkpoint_ms; }
  std::string summary() const;  // one line for logs
};

// What happened between two snapshots of the same counters (b taken before a).
IoStats operator-(const IoStats& a, const IoStats& b);

class IoCounters {
 public:
  std::atomic<uint64_t> loads{0}, saves{0}, removes{0}, bytes_read{0}, bytes_written{0};
  std::atomic<uint64_t> load_ns{0}, save_ns{0}, wait_ns{0}, write_waits{0}, write_wait_ns{0};
  std::atomic<uint64_t> pool_loads{0}, prefetch_hits{0}, write_behind_hits{0}, sync_loads{0}, waits{0};
  std::atomic<uint64_t> evictions_clean{0}, evictions_dirty{0}, evict_copy_ns{0}, upload_ns{0};
  std::atomic<uint64_t> evicting_ns{0}, loading_ns{0}, take_ns{0}, take_lock_ns{0}, read_ahead_full{0}, read_ahead_no_room{0}, reader_writes{0};
  std::atomic<uint64_t> barriers{0}, synced_files{0}, barrier_ns{0}, checkpoints{0}, checkpoint_ns{0};
  std::atomic<uint64_t> checkpoints_behind{0}, checkpoint_behind_ns{0}, flush_gather_ns{0}, flush_commit_ns{0};

  IoStats snapshot() const;
  void reset();
};

// Measures a span of wall time into an atomic nanosecond counter when it ends.
class ScopedTimer {
 public:
  explicit ScopedTimer(std::atomic<uint64_t>& ns) : ns_(ns), start_(std::chrono::steady_clock::now()) {}
  ~ScopedTimer() {
    ns_ += uint64_t(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start_)
            .count());
  }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  std::atomic<uint64_t>& ns_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace chungs
