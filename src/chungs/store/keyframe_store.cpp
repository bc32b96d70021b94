#include "chungs/store/keyframe_store.hpp"

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/store/atomic_file.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {
constexpr const char* kExt = ".keyframe";
constexpr size_t kMaxUnwritten = 32;  // keyframes waiting for their write at most
}

KeyframeStore::KeyframeStore(fs::path folder, const KeyframeStoreConfig& config)
    : folder_(std::move(folder)), config_(config) {
  if (config_.max_in_memory == 0) fail("keyframe store: max_in_memory must be at least 1");
  std::error_code ec;
  fs::create_directories(folder_, ec);
  if (ec) fail(folder_.string(), ": cannot create keyframe folder: ", ec.message());
  remove_temporary_files(folder_);
  for (const auto& e : fs::directory_iterator(folder_, ec)) {
    const std::string stem = e.path().stem().string();
    if (e.path().extension() != kExt || stem.empty() || stem.find_first_not_of("0123456789") != std::string::npos)
      continue;
    on_disk_.insert(std::stoull(stem));
  }
  if (ec) fail(folder_.string(), ": cannot list keyframe folder: ", ec.message());
  // Two threads: reads ahead must not queue behind a write (a write takes 2-3 times as long as a
  // read, and the optimiser needs the read within one step); only the first thread writes, so
  // two writes of one keyframe never race.
  if (config_.background) {
    threads_.emplace_back([this] { worker(false); });
    threads_.emplace_back([this] { worker(true); });
  }
}

KeyframeStore::~KeyframeStore() {
  if (threads_.empty()) return;
  {
    std::unique_lock lock(mutex_);
    drain_locked(lock);
    stop_ = true;
  }
  wake_.notify_all();
  for (auto& t : threads_) t.join();
  if (error_ && !error_reported_) {
    try {
      std::rethrow_exception(error_);
    } catch (const std::exception& e) {
      log::error("keyframe store ", folder_.string(), ": ", e.what());
    }
  }
}

fs::path KeyframeStore::path_of(uint64_t id) const { return folder_ / (std::to_string(id) + kExt); }

void KeyframeStore::cache_locked(uint64_t id, Images images) {
  auto it = cache_.find(id);
  if (it != cache_.end()) {
    lru_.erase(it->second.lru);
    cache_.erase(it);
  }
  lru_.push_front(id);
  cache_.emplace(id, Cached{std::move(images), lru_.begin()});
  while (cache_.size() > config_.max_in_memory) {
    cache_.erase(lru_.back());
    lru_.pop_back();
  }
}

// Sticky: after a failed write the store cannot promise what it holds on disk, so every later
// put and commit fails with the same error (get still serves what it has).
void KeyframeStore::rethrow_locked() {
  if (!error_) return;
  error_reported_ = true;
  std::rethrow_exception(error_);
}

void KeyframeStore::write_now(uint64_t id, const KeyframeImages& images, bool durable) {
  uint64_t bytes;
  {
    ScopedTimer t(counters_.save_ns);
    bytes = write_keyframe_file(path_of(id), id, images, {config_.compress, config_.zstd_level, durable});
  }
  counters_.saves++;
  counters_.bytes_written += bytes;
}

KeyframeStore::Images KeyframeStore::read_now(uint64_t id) {
  KeyframeImages im;
  uint64_t bytes = 0, found;
  {
    ScopedTimer t(counters_.load_ns);
    found = read_keyframe_file(path_of(id), im, &bytes);
  }
  if (found != id) fail(path_of(id).string(), ": header names keyframe ", found, ", expected ", id);
  counters_.loads++;
  counters_.bytes_read += bytes;
  return std::make_shared<const KeyframeImages>(std::move(im));
}

void KeyframeStore::worker(bool reads_only) {
  std::unique_lock lock(mutex_);
  for (;;) {
    // Reads are queued at the front, so a reader looks only there.
    auto usable = [&] { return !jobs_.empty() && (!reads_only || !jobs_.front().write); };
    wake_.wait(lock, [&] { return stop_ || usable(); });
    if (!usable()) return;
    Job job = std::move(jobs_.front());
    jobs_.pop_front();
    ++busy_;
    lock.unlock();
    Images read;
    std::exception_ptr err;
    try {
      if (job.write)  // flushed by commit() in one barrier with the others written since the last
        write_now(job.id, *job.images, false);
      else
        read = read_now(job.id);
    } catch (...) {
      err = std::current_exception();
    }
    lock.lock();
    --busy_;
    if (err && !error_) error_ = err;
    if (job.write) {
      // A newer put of the same keyframe queued another write; it stays until that one is done.
      auto u = unwritten_.find(job.id);
      if (!err && u != unwritten_.end() && u->second == job.images) unwritten_.erase(u);
      if (!err) unsynced_.push_back(job.id);
    } else {
      reading_.erase(job.id);
      if (read && on_disk_.count(job.id) && !cache_.count(job.id)) cache_locked(job.id, std::move(read));
    }
    idle_.notify_all();
  }
}

void KeyframeStore::drain_locked(std::unique_lock<std::mutex>& lock) {
  idle_.wait(lock, [&] { return jobs_.empty() && busy_ == 0; });
}

void KeyframeStore::put(uint64_t id, KeyframeImages images) {
  auto shared = std::make_shared<const KeyframeImages>(std::move(images));
  if (threads_.empty()) {
    write_now(id, *shared, config_.durable);
    std::lock_guard lock(mutex_);
    on_disk_.insert(id);
    cache_locked(id, std::move(shared));
    return;
  }
  {
    std::unique_lock lock(mutex_);
    rethrow_locked();
    if (unwritten_.size() >= kMaxUnwritten) {  // the disk is behind: memory must not grow without end
      ScopedTimer t(counters_.wait_ns);
      counters_.waits++;
      idle_.wait(lock, [&] { return unwritten_.size() < kMaxUnwritten || error_; });
      rethrow_locked();
    }
    on_disk_.insert(id);
    unwritten_[id] = shared;
    cache_locked(id, shared);
    jobs_.push_back(Job{true, id, std::move(shared)});
  }
  wake_.notify_all();
}

KeyframeStore::Images KeyframeStore::get(uint64_t id) {
  {
    std::unique_lock lock(mutex_);
    auto it = cache_.find(id);
    if (it != cache_.end()) {
      lru_.splice(lru_.begin(), lru_, it->second.lru);
      return it->second.images;
    }
    if (auto u = unwritten_.find(id); u != unwritten_.end()) return u->second;
    if (!on_disk_.count(id)) fail(folder_.string(), ": keyframe ", id, " is not stored");
    if (reading_.count(id)) {  // the read-ahead is under way: wait for it rather than read twice
      ScopedTimer t(counters_.wait_ns);
      counters_.waits++;
      idle_.wait(lock, [&] { return !reading_.count(id); });
      if (auto c = cache_.find(id); c != cache_.end()) return c->second.images;
    }
  }
  // Read without the lock so that other keyframes stay available meanwhile: the caller waits.
  Images images;
  {
    ScopedTimer t(counters_.wait_ns);
    counters_.waits++;
    counters_.sync_loads++;
    images = read_now(id);
  }
  std::lock_guard lock(mutex_);
  if (on_disk_.count(id)) cache_locked(id, images);
  return images;
}

void KeyframeStore::prefetch(uint64_t id) {
  if (threads_.empty()) return;
  {
    std::lock_guard lock(mutex_);
    if (cache_.count(id) || unwritten_.count(id) || reading_.count(id) || !on_disk_.count(id)) return;
    reading_.insert(id);
    counters_.prefetch_hits++;  // a read the caller will not wait for (unless it comes too soon)
    jobs_.push_front(Job{false, id, nullptr});  // before queued writes: the optimiser needs it next
  }
  wake_.notify_all();
}

void KeyframeStore::commit(bool caller_waits) {
  std::atomic<uint64_t> unseen{0};
  ScopedTimer whole(caller_waits ? counters_.checkpoint_ns : unseen);  // waits for queued writes and the flush
  if (caller_waits) counters_.checkpoints++;
  std::vector<fs::path> files;
  {
    std::unique_lock lock(mutex_);
    drain_locked(lock);
    rethrow_locked();
    if (!config_.durable) {
      unsynced_.clear();
      return;
    }
    for (uint64_t id : unsynced_)
      if (on_disk_.count(id)) files.push_back(path_of(id));
    unsynced_.clear();
  }
  ScopedTimer t(counters_.barrier_ns);
  counters_.barriers++;
  counters_.synced_files += files.size();
  sync_files(files);
  sync_directory(folder_);
}

bool KeyframeStore::contains(uint64_t id) const {
  std::lock_guard lock(mutex_);
  return on_disk_.count(id) > 0;
}

void KeyframeStore::erase(uint64_t id) {
  std::unique_lock lock(mutex_);
  drain_locked(lock);  // a queued write of it would bring the file back
  remove_file(path_of(id), config_.durable);
  on_disk_.erase(id);
  unwritten_.erase(id);
  auto it = cache_.find(id);
  if (it != cache_.end()) {
    lru_.erase(it->second.lru);
    cache_.erase(it);
  }
}

std::vector<uint64_t> KeyframeStore::ids() const {
  std::lock_guard lock(mutex_);
  return {on_disk_.begin(), on_disk_.end()};
}

size_t KeyframeStore::size() const {
  std::lock_guard lock(mutex_);
  return on_disk_.size();
}

size_t KeyframeStore::in_memory() const {
  std::lock_guard lock(mutex_);
  size_t n = cache_.size();
  for (const auto& [id, im] : unwritten_)
    if (!cache_.count(id)) ++n;
  return n;
}

bool KeyframeStore::is_in_memory(uint64_t id) const {
  std::lock_guard lock(mutex_);
  return cache_.count(id) > 0 || unwritten_.count(id) > 0;
}

}  // namespace chungs
