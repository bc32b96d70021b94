// KeyframeStore: every keyframe's images on disk (<folder>/<id>.keyframe), at most N of them in
// memory (least recently used dropped first). Writes go to a background thread (write-behind) and
// a keyframe stays in memory until its file is written; commit() waits for them and, when durable,
// flushes them and the folder in one barrier, so a checkpoint's keyframe list never names a
// keyframe that a power loss could take. prefetch() reads a keyframe on that thread ahead of use.
// Thread-safe; returned images are shared and immutable, so a caller may keep using a keyframe
// after the cache dropped it. A failed background write is reported by the next call.
#pragma once
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <list>
#include <memory>
#include <mutex>
#include <set>
#include <thread>
#include <unordered_map>
#include <vector>

#include "chungs/store/io_stats.hpp"
#include "chungs/store/keyframe_file.hpp"

namespace chungs {

struct KeyframeStoreConfig {
  size_t max_in_memory = 400;  // keyframes kept in memory (the paper keeps 400 in VRAM)
  bool compress = true;
  int zstd_level = 1;
  bool durable = true;       // commit() flushes what was written since the last one
  bool background = true;    // writes and read-ahead on threads of the store's own
};

class KeyframeStore {
 public:
  using Images = std::shared_ptr<const KeyframeImages>;

  // Opens (or creates) the folder and indexes the keyframe files in it.
  explicit KeyframeStore(std::filesystem::path folder, const KeyframeStoreConfig& config = {});
  // Writes what is queued (not flushed); errors are logged, not thrown.
  ~KeyframeStore();
  KeyframeStore(const KeyframeStore&) = delete;
  KeyframeStore& operator=(const KeyframeStore&) = delete;

  void put(uint64_t id, KeyframeImages images);  // replaces an existing keyframe
  Images get(uint64_t id);                       // throws naming the keyframe when absent
  void prefetch(uint64_t id);                    // a later get() finds it in memory (when it fits)
  // Waits for queued writes; when durable, flushes the files written since the last commit and
  // the folder (counted as a checkpoint in counters() when the caller waits: caller_waits = false
  // for a commit on a background thread). Throws the first background error.
  void commit(bool caller_waits = true);
  bool contains(uint64_t id) const;
  void erase(uint64_t id);
  std::vector<uint64_t> ids() const;  // ascending
  size_t size() const;
  size_t in_memory() const;            // cached keyframes (those waiting for their write included)
  bool is_in_memory(uint64_t id) const;
  std::filesystem::path path_of(uint64_t id) const;
  IoCounters& counters() const { return counters_; }

 private:
  struct Job {
    bool write = false;
    uint64_t id = 0;
    Images images;  // write: what to write
  };
  void cache_locked(uint64_t id, Images images);
  void write_now(uint64_t id, const KeyframeImages& images, bool durable);
  Images read_now(uint64_t id);
  void worker(bool reads_only);
  void drain_locked(std::unique_lock<std::mutex>& lock);  // until no job is queued or running
  void rethrow_locked();

  std::filesystem::path folder_;
  KeyframeStoreConfig config_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::set<uint64_t> on_disk_;      // stored: written, or queued to be
  std::unordered_map<uint64_t, Images> unwritten_;  // queued writes, kept until written
  std::set<uint64_t> reading_;      // prefetches queued or running
  std::vector<uint64_t> unsynced_;  // written since the last commit (durable)
  struct Cached {
    Images images;
    std::list<uint64_t>::iterator lru;
  };
  std::unordered_map<uint64_t, Cached> cache_;
  std::list<uint64_t> lru_;  // front: most recently used
  std::deque<Job> jobs_;
  int busy_ = 0;  // jobs being worked on
  bool stop_ = false;
  std::exception_ptr error_;
  bool error_reported_ = false;  // a caller got error_: closing need not log it again
  std::vector<std::thread> threads_;
  mutable IoCounters counters_;
};

}  // namespace chungs
