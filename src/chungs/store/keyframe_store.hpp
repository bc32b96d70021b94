// KeyframeStore: every keyframe's images on disk (<folder>/<id>.keyframe), at most N of them in
// memory (least recently used dropped first). put() writes through at once, so dropping a
// keyframe from memory never needs a write and a crash never loses a stored keyframe.
// Thread-safe; returned images are shared and immutable, so a caller may keep using a keyframe
// after the cache dropped it.
#pragma once
#include <filesystem>
#include <list>
#include <memory>
#include <mutex>
#include <set>
#include <unordered_map>
#include <vector>

#include "chungs/store/io_stats.hpp"
#include "chungs/store/keyframe_file.hpp"

namespace chungs {

struct KeyframeStoreConfig {
  size_t max_in_memory = 400;  // keyframes kept in memory (the paper keeps 400 in VRAM)
  bool compress = true;
  int zstd_level = 1;
  bool durable = true;
};

class KeyframeStore {
 public:
  using Images = std::shared_ptr<const KeyframeImages>;

  // Opens (or creates) the folder and indexes the keyframe files in it.
  explicit KeyframeStore(std::filesystem::path folder, const KeyframeStoreConfig& config = {});

  void put(uint64_t id, KeyframeImages images);  // replaces an existing keyframe
  Images get(uint64_t id);                       // throws naming the keyframe when absent
  bool contains(uint64_t id) const;
  void erase(uint64_t id);
  std::vector<uint64_t> ids() const;  // ascending
  size_t size() const;
  size_t in_memory() const;
  bool is_in_memory(uint64_t id) const;
  std::filesystem::path path_of(uint64_t id) const;
  IoCounters& counters() const { return counters_; }

 private:
  void cache_locked(uint64_t id, Images images);

  struct Cached {
    Images images;
    std::list<uint64_t>::iterator lru;
  };
  std::filesystem::path folder_;
  KeyframeStoreConfig config_;
  mutable std::mutex mutex_;
  std::set<uint64_t> on_disk_;
  std::unordered_map<uint64_t, Cached> cache_;
  std::list<uint64_t> lru_;  // front: most recently used
  mutable IoCounters counters_;
};

}  // namespace chungs
