// ChunkStore: a map folder on disk holding chunk files (chunks/<id>-<generation>.chunk) and a
// manifest that names, per chunk, the generation holding it (with counts, sizes, checksums) plus
// configuration.
//
// Durability without a flush per save. Every save writes a NEW file (next generation; temporary +
// rename, no flush) and never touches the file the manifest names. commit() is the durability
// barrier: it flushes the files written since the last barrier, then the chunk folder, then
// writes the manifest durably; only then are superseded generations deleted (at the commit after
// the one that superseded them, for readers: see below). A removal of a committed chunk leaves a
// tombstone file (<id>-<generation>.removed) until the next commit.
// Opening takes, per chunk, the newest generation newer than the manifest's that reads back
// whole (payload checksum verified), else the manifest's; tombstones win the same way; anything
// else is an orphan, deleted after the repaired manifest is durable. Hence:
//  - killed process (SIGKILL) at any moment: every chunk at its old or new content;
//  - power loss (durable = true): the map reopens to at least the last commit, every chunk valid
//    (a chunk saved later is adopted only if its file survived intact, else the committed one).
// Files of the version 1 layout (chunks/<id>.chunk, generation 0) are read and superseded.
// Snapshots (a checkpoint written behind the caller): begin_snapshot() fixes the map as it is;
// save_to_snapshot() writes a chunk's content of that moment to a file of its own that only the
// snapshot names (loads keep seeing the live map, which saves go on changing); commit_snapshot()
// makes that map, not the live one, the committed manifest. Every file the pending snapshot names
// is kept (and flushed at its commit) even when the live map supersedes it meanwhile.
// A writer locks the folder (flock) while open: a second writer, in any process, is refused.
// Readers (read_only) take no lock and see one committed manifest while a writer goes on: a file
// that a commit supersedes is deleted only at the commit after it, and a reader opens every file
// its manifest names before reading any, so deletions afterwards cannot reach it. A file gone
// before the reader opened it means two commits passed: it starts over from the new manifest (a
// few times, then gives up with "the map changed faster than it could be read; try again").
// Thread-safe: loads and saves of different chunks may run concurrently (the I/O thread and the
// optimiser); the caller must not save and load the same chunk at the same time.
#pragma once
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
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
  bool shuffle = true;          // byte-shuffle before zstd
  bool durable = true;          // commit() flushes (power-loss safe); off: kill-safe only
  bool verify_on_open = false;  // check every chunk's payload checksum on open (reads the whole map)
  // On open after a crash: true takes chunk files saved after the last commit when they read back
  // whole; false rolls every chunk back to the last commit, so the map matches state that a higher
  // layer committed with it (the mapper's checkpoints: keyframes and run state).
  bool adopt_uncommitted = true;
  // Smaller chunk files (chunk_codec.hpp); memory keeps float32. Each save uses the current
  // setting, files of either kind read back.
  // Half precision by default: 45 % smaller files, no measured loss of quality (bench/README).
  bool half_moments = true;   // Adam moments as binary16: 724 -> 488 bytes per Gaussian
  bool half_sh_rest = true;   // SH beyond DC as binary16 too: -> 398 bytes per Gaussian
  // For readers (export, render): the folder must hold a map; it is read as its manifest commits it,
  // nothing is repaired, created, renamed or deleted, and any write throws. A chunk the manifest
  // lists but whose file is gone is an error naming the file (a writer repairs, a reader does not),
  // unless a writer's commits took it meanwhile (then the reader starts over, see above).
  bool read_only = false;
  void validate() const;  // throws Error naming the key out of range
};

// `base` opened for reading only (read_only above).
inline ChunkStoreConfig reader_config(ChunkStoreConfig base = {}) {
  base.read_only = true;
  return base;
}

// What opening had to repair. A clean close leaves all zeros.
struct StoreOpenReport {
  size_t temporaries_removed = 0;  // half-written files of an interrupted write
  size_t entries_adopted = 0;      // chunk files newer than the manifest's last commit
  size_t entries_updated = 0;      // manifest entries whose file changed after the last commit
  size_t entries_dropped = 0;      // manifest entries whose file was removed after the last commit
  size_t files_rejected = 0;       // newer generations that did not read back whole (power loss)
  size_t orphans = 0;              // superseded generations and tombstones left by a crash
  size_t rereads = 0;  // a reader's: manifests read again because a writer's commits took files meanwhile
  bool repaired() const { return entries_adopted + entries_updated + entries_dropped > 0; }
};

class ChunkStore {
 public:
  // Opens (or creates) the map folder. Throws Error naming the file on a corrupt chunk file or
  // manifest, a chunk file whose header names another chunk, or a folder open elsewhere.
  explicit ChunkStore(std::filesystem::path folder, const ChunkStoreConfig& config = {});
  // Commits a changed manifest (errors are logged: destructors must not throw); with
  // adopt_uncommitted = false it does not, since the caller commits what belongs together, and
  // removes the chunk files written since the last commit instead (the next open would roll them
  // back), so a session that ends in an error leaves the folder as its last commit did.
  ~ChunkStore();
  ChunkStore(const ChunkStore&) = delete;
  ChunkStore& operator=(const ChunkStore&) = delete;

  const std::filesystem::path& folder() const { return folder_; }
  // The file holding the chunk now; for a chunk not in the map, its generation-0 name.
  std::filesystem::path chunk_path(ChunkId id) const;
  std::filesystem::path chunk_file(ChunkId id, uint64_t generation) const;
  std::filesystem::path tombstone_file(ChunkId id, uint64_t generation) const;
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
  // The same into arrays that `place` gives for the chunk's count (memory the caller keeps, e.g. for
  // chunks in flight); on a throw their content is undefined.
  void load_into(ChunkId id, const ChunkPlacer& place) const;
  // Writes the chunk's next generation (kill-safe at once, power-safe after commit()); an empty
  // block removes the chunk.
  void save(ChunkId id, const GaussianBlock& block);
  // How a durable store's new file heads for the disk before the next commit: Start begins its
  // writeback at once, so the commit's barrier mostly waits for what is done; Leave lets the page
  // cache hold it, for content likely replaced before the commit (chunks evicted while the map
  // trains: a refinement under a small budget rewrites each ~16 times, and writing every version
  // out made the disk's write bandwidth its limit, bench/README.md, issue 19).
  enum class Writeback { Start, Leave };
  // The same from arrays held elsewhere.
  void save_arrays(ChunkId id, const ConstBlockArrays& block, Writeback writeback = Writeback::Start);
  void remove(ChunkId id);  // no-op when absent

  void set_config(const std::string& key, const std::string& value);
  std::optional<std::string> config_value(const std::string& key) const;
  // The durability barrier (see above) when anything changed since the last commit. Refused
  // while a snapshot is pending (it would commit the live map under the snapshot's name).
  void commit();

  // Snapshot (see above). One at a time; begin_snapshot() copies the live manifest (its
  // configuration included) and holds every file it names.
  void begin_snapshot();
  bool snapshot_pending() const;
  // The chunk's content as of begin_snapshot() (an empty block: the chunk is not in the snapshot).
  void save_to_snapshot(ChunkId id, const GaussianBlock& block);
  void save_arrays_to_snapshot(ChunkId id, const ConstBlockArrays& block);
  // The durability barrier for the snapshot's map; the live map stays uncommitted.
  void commit_snapshot();
  void abandon_snapshot();  // releases the held files (after a failure; the last commit stands)
  // After a snapshot's commit, for a chunk the caller has not changed since it handed over the
  // snapshot's content: the committed file becomes the live one too (the previous live file is
  // retired), so the chunk need not be written again by the next snapshot or by an eviction.
  // False (nothing changed) when the committed map does not name the chunk, when it already is
  // the live file, or while a snapshot is pending.
  bool adopt_committed(ChunkId id);

  IoCounters& counters() const { return counters_; }

 private:
  struct Retired {
    ChunkId id;
    uint64_t generation;
    bool tombstone;
    // Found on open and not chosen: goes once the repaired manifest is durable, even a tombstone
    // newer than the chunk's entry (rolled back), which a later open with adoption would obey.
    bool orphan = false;
  };
  void reconcile(bool have_manifest);
  void open_read_only();
  void remove_uncommitted_files() const;
  // Opens every file `m` names, or returns the first that is missing (or is not a file).
  std::optional<std::filesystem::path> pin_files(const Manifest& m);
  void delete_deferred();
  void refuse_write(const char* what) const;  // throws when opened read-only
  bool is_committed(ChunkId id, uint64_t generation) const;
  // Writes the chunk's next generation (not yet named anywhere): the generation and the file.
  std::pair<uint64_t, ChunkFileInfo> write_generation(ChunkId id, const ConstBlockArrays& block,
                                                      Writeback writeback = Writeback::Start);
  bool is_current_locked(ChunkId id, uint64_t generation) const;
  // Takes a file out of use. Needs mutex_. When no manifest on disk may name it, it is handed back
  // for the caller to delete once it has released the lock (an unlink can wait for the file's
  // writeback, and under the lock every reader of the store waited with it); else it is kept
  // among the retired until a commit allows its deletion.
  [[nodiscard]] std::optional<Retired> retire(const Retired& r);
  bool deletable_after(const Retired& r, const Manifest& durable) const;
  void delete_file(const Retired& r) const;
  bool is_held(ChunkId id, uint64_t generation) const;
  // A commit in two parts: under mutex_, what of `snapshot` needs flushing (and no superseded
  // file may be deleted from then on); then, unlocked, the flushes, the manifest write and the
  // deletion of what it made obsolete. `dirty_` is the caller's business.
  std::vector<std::pair<ChunkId, uint64_t>> start_commit_locked(const Manifest& snapshot);
  void commit_manifest(const Manifest& snapshot, const std::vector<std::pair<ChunkId, uint64_t>>& to_sync);

  std::filesystem::path folder_, chunk_dir_;
  ChunkStoreConfig config_;
  double chunk_size_;
  int sh_degree_;
  StoreOpenReport report_;
  FileDescriptor lock_;
  mutable std::mutex mutex_;  // guards everything below but counters_
  std::mutex commit_mutex_;   // one manifest write at a time
  Manifest manifest_;
  bool dirty_ = false;
  bool committing_ = false;  // a commit() is between snapshot and manifest
  uint64_t next_generation_ = 1;
  std::set<uint64_t> writing_;                       // generations being written (not yet in manifest_)
  std::map<ChunkId, ManifestEntry> committed_;       // entries the manifest on disk names
  std::set<std::pair<ChunkId, uint64_t>> unsynced_;  // chunk files written since the last barrier
  std::vector<Retired> retired_;                     // waiting for a commit before deletion
  // Named by the manifest before the last commit: a reader may still be opening them (see above).
  std::vector<Retired> deferred_;
  // A reader's open files, one per chunk of its manifest; the mutex keeps two loads of one chunk
  // from moving the shared file offset under each other.
  struct Pin {
    FileDescriptor fd;
    std::unique_ptr<std::mutex> mutex = std::make_unique<std::mutex>();
  };
  std::map<ChunkId, Pin> pins_;
  std::optional<Manifest> snapshot_;                 // pending snapshot (begin_snapshot)
  std::set<std::pair<ChunkId, uint64_t>> held_;      // files it names: kept until its commit
  mutable IoCounters counters_;
};

}  // namespace chungs
