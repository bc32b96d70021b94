#include "chungs/store/keyframe_store.hpp"

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {
constexpr const char* kExt = ".keyframe";
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

void KeyframeStore::put(uint64_t id, KeyframeImages images) {
  auto shared = std::make_shared<const KeyframeImages>(std::move(images));
  uint64_t bytes;
  {
    ScopedTimer t(counters_.save_ns);
    bytes = write_keyframe_file(path_of(id), id, *shared,
                                {config_.compress, config_.zstd_level, config_.durable});
  }
  counters_.saves++;
  counters_.bytes_written += bytes;
  std::lock_guard lock(mutex_);
  on_disk_.insert(id);
  cache_locked(id, std::move(shared));
}

KeyframeStore::Images KeyframeStore::get(uint64_t id) {
  {
    std::lock_guard lock(mutex_);
    auto it = cache_.find(id);
    if (it != cache_.end()) {
      lru_.splice(lru_.begin(), lru_, it->second.lru);
      return it->second.images;
    }
    if (!on_disk_.count(id)) fail(folder_.string(), ": keyframe ", id, " is not stored");
  }
  // Read without the lock so that other keyframes stay available meanwhile.
  KeyframeImages im;
  uint64_t bytes = 0, found;
  {
    ScopedTimer t(counters_.load_ns);
    found = read_keyframe_file(path_of(id), im, &bytes);
  }
  if (found != id) fail(path_of(id).string(), ": header names keyframe ", found, ", expected ", id);
  counters_.loads++;
  counters_.bytes_read += bytes;
  auto shared = std::make_shared<const KeyframeImages>(std::move(im));
  std::lock_guard lock(mutex_);
  if (on_disk_.count(id)) cache_locked(id, shared);
  return shared;
}

bool KeyframeStore::contains(uint64_t id) const {
  std::lock_guard lock(mutex_);
  return on_disk_.count(id) > 0;
}

void KeyframeStore::erase(uint64_t id) {
  std::lock_guard lock(mutex_);
  remove_file(path_of(id), config_.durable);
  on_disk_.erase(id);
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
  return cache_.size();
}

bool KeyframeStore::is_in_memory(uint64_t id) const {
  std::lock_guard lock(mutex_);
  return cache_.count(id) > 0;
}

}  // namespace chungs
