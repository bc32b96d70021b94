#include "chungs/residency/io_worker.hpp"

#include <algorithm>
#include <unordered_set>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"

namespace chungs {

IoWorker::IoWorker(ChunkStore& store, HostBlockPool& blocks, bool background, size_t prefetch_max,
                   size_t write_behind_max, int threads)
    : store_(store), blocks_(blocks), counters_(store.counters()), background_(background), prefetch_max_(prefetch_max),
      write_behind_max_(write_behind_max) {
  if (threads < 1) fail("chunk I/O: at least one thread is needed, got ", threads);
  if (!background_) return;
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this, i] { run(i); });
}

IoWorker::~IoWorker() {
  if (!background_) return;
  try {
    drain();
  } catch (const std::exception& e) {
    log::error("chunk I/O: queued writes failed on shutdown: ", e.what());
  }
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  work_cv_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void IoWorker::rethrow_locked() {
  if (error_) std::rethrow_exception(error_);
}

void IoWorker::write_now(ChunkId id, const Block& data) {
  if (data->size() == 0)
    store_.remove(id);
  else
    store_.save_arrays(id, data->arrays(), ChunkStore::Writeback::Leave);  // may be loaded and evicted again
}

void IoWorker::write_behind(ChunkId id, Block data) {
  if (!data) fail("chunk I/O: write-behind of ", chunk_name(id), " without data");
  if (!background_) {
    ScopedTimer t(counters_.wait_ns);
    counters_.waits++;
    write_now(id, data);
    return;
  }
  std::unique_lock lock(mutex_);
  rethrow_locked();
  if (pending_gaussians_ > write_behind_max_) {
    // Back-pressure: the disk is slower than eviction. Waiting bounds the memory held here.
    ScopedTimer t(counters_.wait_ns), tw(counters_.write_wait_ns);
    counters_.waits++;
    counters_.write_waits++;
    done_cv_.wait(lock, [&] { return pending_gaussians_ <= write_behind_max_ || error_; });
    rethrow_locked();
  }
  Pending& p = pending_[id];
  if (p.data) pending_gaussians_ -= p.data->size();
  pending_gaussians_ += data->size();
  p.data = std::move(data);
  if (!p.queued) {
    p.queued = true;
    write_queue_.push_back(id);
  }
  // A staged copy would now be stale; it cannot exist (the chunk was resident), but be certain.
  if (auto it = staged_.find(id); it != staged_.end()) {
    staged_gaussians_ -= it->second->size();
    staged_.erase(it);
    std::erase(staged_order_, id);
  }
  lock.unlock();
  // One write, one thread: waking all of them (one per core) for every eviction cost the evicting
  // caller twice its time with 16 of them (bench_store_io, BM_RefinementVisits). A thread that is busy
  // finds the write when it looks for its next work.
  work_cv_.notify_one();
}

void IoWorker::prefetch(const std::vector<std::pair<ChunkId, uint64_t>>& chunks) {
  if (!background_) return;
  bool queued = false;
  {
    std::lock_guard lock(mutex_);
    prefetch_queue_.clear();
    wanted_.clear();
    for (const auto& c : chunks) {
      wanted_.insert(c.first);
      if (!staged_.count(c.first) && !pending_.count(c.first) && !reading_.count(c.first)) prefetch_queue_.push_back(c);
    }
    queued = !prefetch_queue_.empty();
  }
  // All: a thread busy writing may take the notice. None when nothing is to be read: this comes every
  // step, and woke every I/O thread (one per core) to find nothing, each taking the lock the step's own
  // chunk reads need.
  if (queued) work_cv_.notify_all();
}

IoWorker::Block IoWorker::take(ChunkId id, Source* source) {
  std::vector<Source> sources;
  std::vector<Block> blocks = take_many(std::span(&id, 1), sources);
  if (source) *source = sources[0];
  return std::move(blocks[0]);
}

std::vector<IoWorker::Block> IoWorker::take_many(std::span<const ChunkId> ids, std::vector<Source>& sources) {
  std::vector<Block> out(ids.size());
  sources.assign(ids.size(), Source::Absent);
  std::vector<size_t> unread;  // not in memory: read on the caller's thread
  if (background_) {
    std::unique_lock lock(mutex_, std::defer_lock);
    {
      ScopedTimer t(counters_.take_lock_ns);
      lock.lock();
    }
    const std::unordered_set<ChunkId> wanted(ids.begin(), ids.end());
    std::erase_if(prefetch_queue_, [&](const auto& c) { return wanted.count(c.first) > 0; });
    bool took_staged = false;
    for (size_t i = 0; i < ids.size(); ++i) {
      const ChunkId id = ids[i];
      if (auto it = pending_.find(id); it != pending_.end()) {
        sources[i] = Source::WriteBehind;
        out[i] = it->second.data;
        continue;
      }
      if (reading_.count(id)) {
        ScopedTimer t(counters_.wait_ns);
        counters_.waits++;
        done_cv_.wait(lock, [&] { return !reading_.count(id); });
        sources[i] = Source::InFlight;
      } else {
        sources[i] = Source::Prefetched;
      }
      if (auto it = staged_.find(id); it != staged_.end()) {
        out[i] = std::move(it->second);
        staged_gaussians_ -= out[i]->size();
        staged_.erase(it);
        took_staged = true;
        continue;
      }
      unread.push_back(i);
    }
    if (took_staged) std::erase_if(staged_order_, [&](ChunkId c) { return wanted.count(c) && !staged_.count(c); });
  } else {
    for (size_t i = 0; i < ids.size(); ++i) unread.push_back(i);
  }
  for (size_t i : unread) {
    if (!store_.contains(ids[i])) {
      sources[i] = Source::Absent;
      out[i] = std::make_shared<const HostBlock>();
      continue;
    }
    sources[i] = Source::Disk;
    ScopedTimer t(counters_.wait_ns);
    counters_.waits++;
    std::shared_ptr<HostBlock> block = blocks_.make(store_.count(ids[i]), store_.sh_degree());
    store_.load_into(ids[i], [&](uint64_t, int) { return block->arrays(); });  // the read checks the count
    out[i] = std::move(block);
  }
  return out;
}

void IoWorker::drain() {
  if (!background_) return;
  std::unique_lock lock(mutex_);
  if (error_) {
    // Try the failed write again (its block is still queued): a full disk that the user cleared
    // must not leave the map unwritable for the rest of the run. Said aloud, since a retry that
    // succeeds would otherwise hide that the disk failed once.
    try {
      std::rethrow_exception(error_);
    } catch (const std::exception& e) {
      log::warn("chunk I/O: a write behind failed (", e.what(), "); trying it again");
    }
    error_ = nullptr;
    work_cv_.notify_all();
  }
  done_cv_.wait(lock, [&] { return (write_queue_.empty() && writing_.empty()) || error_; });
  rethrow_locked();
}

size_t IoWorker::queued_write_gaussians() const {
  std::lock_guard lock(mutex_);
  return pending_gaussians_;
}

size_t IoWorker::staged_gaussians() const {
  std::lock_guard lock(mutex_);
  return staged_gaussians_;
}

std::deque<ChunkId>::iterator IoWorker::next_writable() {
  return std::find_if(write_queue_.begin(), write_queue_.end(), [&](ChunkId id) { return !writing_.count(id); });
}

bool IoWorker::write_one(std::unique_lock<std::mutex>& lock) {
  if (error_) return false;
  const auto next = next_writable();
  if (next == write_queue_.end()) return false;
  const ChunkId id = *next;
  write_queue_.erase(next);
  Pending& p = pending_.at(id);
  p.queued = false;
  Block data = p.data;
  writing_.insert(id);
  lock.unlock();
  std::exception_ptr err;
  try {
    write_now(id, data);
  } catch (...) {
    err = std::current_exception();
  }
  lock.lock();
  writing_.erase(id);
  if (err) {
    // Keep the block: loads still get it, and the caller learns of the failure on its next call.
    error_ = err;
    auto& q = pending_.at(id);
    if (!q.queued) q.queued = true, write_queue_.push_front(id);
  } else if (auto it = pending_.find(id); it != pending_.end() && it->second.data == data) {
    pending_gaussians_ -= data->size();
    pending_.erase(it);  // only now may loads go to disk: the file holds this content
  }
  // Those waiting for a write (a full queue, a drain, a read of this chunk). No I/O thread needs
  // waking: this one looks for its next work now, a chunk queued again meanwhile included.
  done_cv_.notify_all();
  return true;
}

bool IoWorker::prefetch_one(std::unique_lock<std::mutex>& lock) {
  while (!prefetch_queue_.empty()) {
    const auto [id, count] = prefetch_queue_.front();
    prefetch_queue_.pop_front();
    if (staged_.count(id) || pending_.count(id) || reading_.count(id)) continue;
    // Make room by dropping the oldest reads the latest prediction no longer names; give up on
    // chunks that can never fit. Reads it still names are for nearer steps than this one (the list
    // is in the order of use): when only those are left, reading further ahead waits for the next
    // prediction, which comes once a step has taken some of them.
    if (count > prefetch_max_) continue;
    while (staged_gaussians_ + reading_gaussians_ + count > prefetch_max_) {
      const auto stale = std::find_if(staged_order_.begin(), staged_order_.end(),
                                      [&](ChunkId c) { return !wanted_.count(c); });
      if (stale == staged_order_.end()) {
        counters_.read_ahead_full++;
        prefetch_queue_.clear();
        return false;
      }
      const ChunkId old = *stale;
      staged_order_.erase(stale);
      if (auto it = staged_.find(old); it != staged_.end()) {
        staged_gaussians_ -= it->second->size();
        staged_.erase(it);
      }
    }
    // No room in the pool (queued writes and checkpoint copies hold it): like a full read-ahead,
    // reading further waits for the next prediction; the heap is not the place for a guess.
    std::shared_ptr<HostBlock> block = blocks_.make_in_pool(count, store_.sh_degree());
    if (!block) {
      counters_.read_ahead_no_room++;
      prefetch_queue_.clear();
      return false;
    }
    reading_.insert(id);
    reading_gaussians_ += count;
    lock.unlock();
    Block data;
    try {
      if (store_.contains(id)) {
        store_.load_into(id, [&](uint64_t, int) { return block->arrays(); });  // the read checks the count
        data = std::move(block);
      }
    } catch (const std::exception& e) {
      // The caller's own read of this chunk reads it again and fails where it can act, or succeeds
      // (a transient error): said aloud either way, since a disk that failed once is worth knowing.
      log::warn("chunk I/O: reading ahead ", chunk_name(id), " failed (", e.what(), "); it is read again when needed");
    }
    lock.lock();
    reading_.erase(id);
    reading_gaussians_ -= count;
    if (data) {
      staged_gaussians_ += data->size();
      staged_[id] = std::move(data);
      std::erase(staged_order_, id);
      staged_order_.push_back(id);
    }
    done_cv_.notify_all();
    return true;
  }
  return false;
}

void IoWorker::run(int index) {
  std::unique_lock lock(mutex_);
  for (;;) {
    // Reads first unless the write queue is half full: the caller waits on missing reads now,
    // but on writes only once the queue is full. The first thread always reads first: in a
    // refinement under a small budget the queue stays half full, and the reads that then waited
    // for every thread's writes were most of the optimiser's wait (GPU, bench/README.md, issue 19).
    const bool writes_urgent = index > 0 && pending_gaussians_ * 2 > write_behind_max_;
    if (writes_urgent && write_one(lock)) {
      counters_.reader_writes++;
      continue;
    }
    if (prefetch_one(lock)) continue;
    if (write_one(lock)) continue;
    if (stop_) return;
    work_cv_.wait(lock, [&] {
      return stop_ || (next_writable() != write_queue_.end() && !error_) || !prefetch_queue_.empty();
    });
  }
}

}  // namespace chungs
