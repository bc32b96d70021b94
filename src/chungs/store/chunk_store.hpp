// ChunkStore: a map folder on disk holding one file per chunk (chunks/<id>.chunk) and a manifest.
// Chunk files are the truth for chunk content; the manifest indexes them (counts, sizes,
// checksums) plus configuration. Saving a chunk replaces its file crash-safely at once; commit()
// rewrites the manifest. Opening reconciles the two, so after a crash at any moment the folder
// reopens with every chunk at its old or new content and a manifest that matches the files.
// A folder is locked (flock) while open: a second ChunkStore on it, in any process, is refused.
// Thread-safe: loads and saves of different chunks may run concurrently (the I/O thread and the
// optimiser); the caller must not save and load the same chunk at the same time.
#pragma once
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/chunk_file.hpp"
#include "chungs/store/chunk_id.hpp"
#include "chungs/store/io_stats.hpp"
#include "chungs/store/manifest.hpp"

namespace chungs {

struct ChunkStoreConfig {
  double chunk_size = 10.0;  // metres; used for a new map, an existing map keeps its own
  int sh_degree = 3;         // recorded for a new map
  bool compress = false;     // zstd on chunk files (see bench/README.md for the trade-off)
  int zstd_level = 1;
  bool shuffle = true;         // byte-shuffle before zstd
  bool durable = true;         // flush files and folders (power-loss safe); off: kill-safe only
  bool verify_on_open = false; // check every chunk's payload checksum on open (reads the whole map)
};

// What opening had to repair. A clean close leaves all zeros.
struct StoreOpenReport {
  size_t temporaries_removed = 0;  // half-written files of an interrupted write
  size_t entries_adopted = 0;      // chunk files newer than the manifest's last commit
  size_t entries_updated = 0;      // manifest entries whose file changed after the last commit
  size_t entries_dropped = 0;      // manifest entries whose file was removed after the last commit
  bool repaired() const { return entries_adopted + entries_updated + entries_dropped > 0; }
};

class ChunkStore {
 public:
  // Opens (or creates) the map folder. Throws Error naming the file on a corrupt chunk file or
  // manifest, a chunk file whose header names another chunk, or a folder open elsewhere.
  explicit ChunkStore(std::filesystem::path folder, const ChunkStoreConfig& config = {});
  ~ChunkStore();  // commits a changed manifest (errors are logged: destructors must not throw)
  ChunkStore(const ChunkStore&) = delete;
  ChunkStore& operator=(const ChunkStore&) = delete;

  const std::filesystem::path& folder() const { return folder_; }
  std::filesystem::path chunk_path(ChunkId id) const;
  std::filesystem::path manifest_path() const { return folder_ / "manifest.txt"; }
  double chunk_size() const { return chunk_size_; }
  int sh_degree() const { return sh_degree_; }
  const ChunkStoreConfig& config() const { return config_; }
  const StoreOpenReport& open_report() const { return report_; }

  bool contains(ChunkId id) const;
  uint64_t count(ChunkId id) const;  // 0 when the chunk does not exist
  std::vector<ChunkId> ids() const;  // ascending
  std::vector<std::pair<ChunkId, uint64_t>> counts() const;
  size_t size() const;
  uint64_t total_gaussians() const;
  Manifest manifest() const;  // a copy of the in-memory manifest

  GaussianBlock load(ChunkId id) const;  // throws naming the chunk when absent or corrupt
  // Replaces the chunk's file; an empty block removes the chunk.
  void save(ChunkId id, const GaussianBlock& block);
  void remove(ChunkId id);  // no-op when absent

  void set_config(const std::string& key, const std::string& value);
  std::optional<std::string> config_value(const std::string& key) const;
  void commit();  // writes the manifest if anything changed since the last commit

  IoCounters& counters() const { return counters_; }

 private:
  void reconcile(bool have_manifest);

  std::filesystem::path folder_, chunk_dir_;
  ChunkStoreConfig config_;
  double chunk_size_;
  int sh_degree_;
  StoreOpenReport report_;
  FileDescriptor lock_;
  mutable std::mutex mutex_;   // guards manifest_ and dirty_
  std::mutex commit_mutex_;    // one manifest write at a time
  Manifest manifest_;
  bool dirty_ = false;
  mutable IoCounters counters_;
};

}  // namespace chungs
