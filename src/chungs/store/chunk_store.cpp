#include "chungs/store/chunk_store.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <optional>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/store/chunk_file_name.hpp"
#include "chungs/store/map_folder.hpp"

namespace chungs {

namespace fs = std::filesystem;

void ChunkStoreConfig::validate() const {
  if (!(chunk_size >= kMinChunkSize && chunk_size <= kMaxChunkSize))
    fail("store: chunk_size must be in [", kMinChunkSize, ", ", kMaxChunkSize, "] metres, got ", chunk_size);
  if (sh_degree < 0 || sh_degree > kMaxShDegree) fail("store: sh_degree must be in [0, ", kMaxShDegree, "], got ", sh_degree);
  if (zstd_level < 1 || zstd_level > 22) fail("store: zstd_level must be in [1, 22], got ", zstd_level);
}

ChunkStore::ChunkStore(fs::path folder, const ChunkStoreConfig& config)
    : folder_(std::move(folder)),
      chunk_dir_(folder_ / "chunks"),
      config_(config),
      chunk_size_(config.chunk_size),
      sh_degree_(config.sh_degree) {
  if (!(chunk_size_ > 0)) fail("chunk store: chunk size must be positive, got ", chunk_size_);
  if (config_.read_only) {
    open_read_only();
    return;
  }
  std::error_code ec;
  fs::create_directories(chunk_dir_, ec);
  if (ec) fail(chunk_dir_.string(), ": cannot create map folder: ", ec.message());
  const fs::path lock_file = folder_ / "lock";
  lock_ = FileDescriptor(::open(lock_file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
  if (!lock_) fail(lock_file.string(), ": cannot open: ", std::strerror(errno));
  if (::flock(lock_.get(), LOCK_EX | LOCK_NB) != 0)
    fail(folder_.string(), ": map folder is already open (by this or another process)");

  report_.temporaries_removed = remove_temporary_files(folder_) + remove_temporary_files(chunk_dir_);
  const bool have_manifest = fs::exists(manifest_path());
  if (have_manifest) {
    try {
      manifest_ = Manifest::read(manifest_path());
    } catch (const Error& e) {
      fail(e.what(), " (delete it, and `run --resume` rebuilds it from the chunk files)");
    }
    if (manifest_.chunk_size != config.chunk_size)
      log::info(folder_.string(), ": map uses chunk size ", manifest_.chunk_size, " m (config asked ",
                config.chunk_size, " m)");
    chunk_size_ = manifest_.chunk_size;
    sh_degree_ = manifest_.sh_degree;
  } else {
    manifest_.chunk_size = chunk_size_;
    manifest_.sh_degree = sh_degree_;
  }
  reconcile(have_manifest);
  if (!have_manifest || report_.repaired() || !retired_.empty()) {
    dirty_ = true;
    commit();
  }
}

void ChunkStore::open_read_only() {
  // No lock: a running writer keeps what its previous manifest names until its next commit, so
  // the files of the manifest read here are all there unless two commits passed before they were
  // opened; then the manifest has moved on and the read starts over from it.
  constexpr int kAttempts = 5;
  auto read_manifest = [&] {
    require_map_manifest(folder_);
    try {
      return Manifest::read(manifest_path());
    } catch (const Error& e) {
      fail(e.what(), " (delete it, and `run --resume` rebuilds it from the chunk files)");
    }
  };
  Manifest m = read_manifest();
  for (int attempt = 1;; ++attempt) {
    const auto missing = pin_files(m);
    if (!missing) break;
    pins_.clear();
    Manifest now = read_manifest();
    if (now.chunks == m.chunks && now.next_generation == m.next_generation && now.config == m.config)
      fail(missing->string(), ": listed in ", manifest_path().string(),
           " but missing (or not a file); the map is left as it is");
    if (attempt == kAttempts)
      fail(folder_.string(), ": the map changed faster than it could be read; try again");
    ++report_.rereads;
    log::info(folder_.string(), ": the map was committed again while it was opened; reading the new commit");
    m = std::move(now);
  }
  manifest_ = std::move(m);
  chunk_size_ = manifest_.chunk_size;
  sh_degree_ = manifest_.sh_degree;
  committed_ = manifest_.chunks;
  next_generation_ = std::max<uint64_t>(manifest_.next_generation, 1);
}

std::optional<fs::path> ChunkStore::pin_files(const Manifest& m) {
  // One descriptor per chunk: a map of more chunks than the soft limit allows takes the hard one.
  struct rlimit lim{};
  if (::getrlimit(RLIMIT_NOFILE, &lim) == 0 && lim.rlim_cur != RLIM_INFINITY &&
      lim.rlim_cur < m.chunks.size() + 256) {
    lim.rlim_cur = lim.rlim_max == RLIM_INFINITY ? m.chunks.size() + 256 : std::min<rlim_t>(lim.rlim_max, m.chunks.size() + 256);
    ::setrlimit(RLIMIT_NOFILE, &lim);
  }
  for (const auto& [id, e] : m.chunks) {
    const fs::path file = chunk_file(id, e.generation);
    // Non-blocking: a FIFO in a chunk's place must not hang the reader (regular files ignore it).
    FileDescriptor fd(::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK));
    if (!fd) {
      if (errno == ENOENT) return file;
      if (errno == EMFILE || errno == ENFILE)
        fail(folder_.string(), ": a reader holds every chunk file open and ", m.chunks.size(),
             " are more than this process may open; raise the limit (ulimit -n)");
      fail(file.string(), ": cannot open for reading: ", std::strerror(errno));
    }
    struct stat st{};
    if (::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode)) return file;
    pins_.emplace(id, Pin{std::move(fd)});
  }
  return std::nullopt;
}

void ChunkStore::refuse_write(const char* what) const {
  if (config_.read_only) fail(folder_.string(), ": opened read-only, cannot ", what);
}

ChunkStore::~ChunkStore() {
  if (config_.read_only) return;
  try {
    if (config_.adopt_uncommitted) {
      commit();
      delete_deferred();  // no next commit will come; a reader that lost a file starts over
    } else {
      remove_uncommitted_files();
    }
  } catch (const std::exception& e) {
    if (config_.adopt_uncommitted) {
      log::error(folder_.string(), ": could not write the manifest on close: ", e.what());
    } else {
      // The manifest on disk names none of these files, and a later session writing to the map retires
      // what it does not name (ChunkStore::open's orphans), so the map is whole: a warning, not a failed run.
      log::warn(folder_.string(), ": could not remove files the last commit does not name on close ",
                "(a later session writing to the map removes them): ", e.what());
    }
  }
}

void ChunkStore::remove_uncommitted_files() const {
  // The manifest on disk, not committed_: what the next open goes by, even after a commit that
  // failed late (the manifest renamed, its folder not flushed).
  const Manifest durable = Manifest::read(manifest_path());
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(chunk_dir_, ec)) {
    const auto name = parse_chunk_file_name(e.path().filename().string());
    if (!name) continue;
    const auto it = durable.chunks.find(name->id);
    if (name->tombstone || it == durable.chunks.end() || it->second.generation != name->generation)
      remove_file(e.path(), false);
  }
  if (ec) fail(chunk_dir_.string(), ": cannot list chunk files: ", ec.message());
}

fs::path ChunkStore::chunk_path(ChunkId id) const {
  uint64_t generation = 0;
  {
    std::lock_guard lock(mutex_);
    auto it = manifest_.chunks.find(id);
    if (it != manifest_.chunks.end()) generation = it->second.generation;
  }
  return chunk_file(id, generation);
}

fs::path ChunkStore::chunk_file(ChunkId id, uint64_t generation) const {
  return chunk_dir_ / chunk_file_name(id, generation, false);
}

fs::path ChunkStore::tombstone_file(ChunkId id, uint64_t generation) const {
  return chunk_dir_ / chunk_file_name(id, generation, true);
}

bool ChunkStore::contains(ChunkId id) const {
  std::lock_guard lock(mutex_);
  return manifest_.chunks.count(id) > 0;
}

uint64_t ChunkStore::count(ChunkId id) const {
  std::lock_guard lock(mutex_);
  auto it = manifest_.chunks.find(id);
  return it == manifest_.chunks.end() ? 0 : it->second.count;
}

std::vector<ChunkId> ChunkStore::ids() const {
  std::lock_guard lock(mutex_);
  std::vector<ChunkId> out;
  out.reserve(manifest_.chunks.size());
  for (const auto& [id, e] : manifest_.chunks) out.push_back(id);
  return out;
}

std::vector<std::pair<ChunkId, uint64_t>> ChunkStore::counts() const {
  std::lock_guard lock(mutex_);
  std::vector<std::pair<ChunkId, uint64_t>> out;
  out.reserve(manifest_.chunks.size());
  for (const auto& [id, e] : manifest_.chunks) out.emplace_back(id, e.count);
  return out;
}

size_t ChunkStore::size() const {
  std::lock_guard lock(mutex_);
  return manifest_.chunks.size();
}

uint64_t ChunkStore::total_gaussians() const {
  std::lock_guard lock(mutex_);
  return manifest_.total_gaussians();
}

Manifest ChunkStore::manifest() const {
  std::lock_guard lock(mutex_);
  return manifest_;
}

GaussianBlock ChunkStore::load(ChunkId id) const {
  GaussianBlock b;
  load_into(id, [&](uint64_t count, int sh_degree) {
    b.sh_degree = sh_degree;
    b.resize(count);
    return block_arrays(b);
  });
  return b;
}

void ChunkStore::load_into(ChunkId id, const ChunkPlacer& place) const {
  ManifestEntry entry;
  {
    std::lock_guard lock(mutex_);
    auto it = manifest_.chunks.find(id);
    if (it == manifest_.chunks.end()) fail(folder_.string(), ": ", chunk_name(id), " is not in this map");
    entry = it->second;
  }
  const fs::path file = chunk_file(id, entry.generation);
  ChunkFileInfo info;
  {
    ScopedTimer t(counters_.load_ns);
    const auto pin = pins_.find(id);  // a reader's; fixed after opening, so read unlocked
    if (pin != pins_.end()) {
      std::lock_guard one_reader(*pin->second.mutex);
      info = read_chunk_file(pin->second.fd, file, place);
    } else {
      info = read_chunk_file(open_for_reading(file), file, place);
    }
  }
  if (info.id != id)
    fail(file.string(), ": header names ", chunk_name(info.id), ", expected ", chunk_name(id));
  // Budgets, pools and totals go by the manifest: a file that disagrees with it is not the chunk the
  // map lists (render printed the manifest's count, export wrote the file's).
  if (info.count != entry.count)
    fail(file.string(), ": holds ", info.count, " Gaussians, the manifest lists ", entry.count);
  if (info.file_bytes != entry.file_bytes)
    fail(file.string(), ": has ", info.file_bytes, " bytes, the manifest lists ", entry.file_bytes);
  // The file verified its payload against its own header; this ties that payload to the manifest.
  if (info.payload_checksum != entry.checksum)
    fail(file.string(), ": payload checksum ", info.payload_checksum, " differs from the manifest's ", entry.checksum);
  if (info.sh_degree != sh_degree_)
    fail(file.string(), ": has SH degree ", info.sh_degree, ", the map's is ", sh_degree_);
  counters_.loads++;
  counters_.bytes_read += info.file_bytes;
}

void ChunkStore::save(ChunkId id, const GaussianBlock& block) {
  refuse_write("save a chunk");
  if (block.size() > 0) block.validate(cat(folder_.string(), ": ", chunk_name(id)).c_str());
  save_arrays(id, block_arrays(block));
}

void ChunkStore::save_arrays(ChunkId id, const ConstBlockArrays& block, Writeback writeback) {
  refuse_write("save a chunk");
  if (block.count == 0) {
    remove(id);
    return;
  }
  const auto [generation, info] = write_generation(id, block, writeback);
  std::optional<Retired> doomed;
  {
    std::lock_guard lock(mutex_);
    auto [it, fresh] = manifest_.chunks.try_emplace(id);
    if (!fresh) doomed = retire({id, it->second.generation, false});
    it->second = {info.count, info.file_bytes, info.payload_checksum, generation};
    if (config_.durable) unsynced_.insert({id, generation});
    dirty_ = true;
  }
  if (doomed) delete_file(*doomed);
}

std::pair<uint64_t, ChunkFileInfo> ChunkStore::write_generation(ChunkId id, const ConstBlockArrays& block,
                                                                 Writeback writeback) {
  const ChunkWriteOptions opt{config_.compress,     config_.zstd_level,   config_.shuffle,
                              false,                config_.half_moments, config_.half_sh_rest,
                              config_.durable && writeback == Writeback::Start};
  uint64_t generation;
  {
    std::lock_guard lock(mutex_);
    generation = next_generation_++;
    writing_.insert(generation);
  }
  ChunkFileInfo info;
  try {
    ScopedTimer t(counters_.save_ns);
    info = write_chunk_file(chunk_file(id, generation), id, block, opt);
  } catch (...) {
    std::lock_guard lock(mutex_);
    writing_.erase(generation);
    throw;
  }
  counters_.saves++;
  counters_.bytes_written += info.file_bytes;
  std::lock_guard lock(mutex_);
  writing_.erase(generation);
  return {generation, info};
}

void ChunkStore::remove(ChunkId id) {
  refuse_write("remove a chunk");
  uint64_t generation;
  {
    std::lock_guard lock(mutex_);
    if (!manifest_.chunks.count(id)) return;
    generation = next_generation_++;
    writing_.insert(generation);
  }
  // The tombstone keeps a killed process from bringing back the chunk's committed file.
  try {
    write_file_atomically(tombstone_file(id, generation), {}, false);
  } catch (...) {
    std::lock_guard lock(mutex_);
    writing_.erase(generation);
    throw;
  }
  counters_.removes++;
  std::optional<Retired> doomed[2];
  {
    std::lock_guard lock(mutex_);
    writing_.erase(generation);
    auto it = manifest_.chunks.find(id);
    if (it != manifest_.chunks.end()) {
      doomed[0] = retire({id, it->second.generation, false});
      manifest_.chunks.erase(it);
    }
    doomed[1] = retire({id, generation, true});
    dirty_ = true;
  }
  for (const auto& d : doomed)
    if (d) delete_file(*d);
}

bool ChunkStore::is_committed(ChunkId id, uint64_t generation) const {
  auto it = committed_.find(id);
  return it != committed_.end() && it->second.generation == generation;
}

bool ChunkStore::is_held(ChunkId id, uint64_t generation) const { return held_.count({id, generation}) > 0; }

std::optional<ChunkStore::Retired> ChunkStore::retire(const Retired& r) {
  const bool held = !r.tombstone && is_held(r.id, r.generation);
  if (!r.tombstone && !held) unsynced_.erase({r.id, r.generation});
  // Named by no manifest, committed or to be: nothing can ask for it once the lock is released.
  if (!r.tombstone && !held && !committing_ && !is_committed(r.id, r.generation)) return r;
  retired_.push_back(r);
  return std::nullopt;
}

bool ChunkStore::deletable_after(const Retired& r, const Manifest& durable) const {
  if (r.orphan) return true;
  auto it = durable.chunks.find(r.id);
  if (it == durable.chunks.end()) return true;
  return r.tombstone ? it->second.generation > r.generation : it->second.generation != r.generation;
}

void ChunkStore::delete_file(const Retired& r) const {
  // No flush: a deletion lost to power loss leaves a file of a generation below the manifest's
  // next_generation that the manifest does not name, which opening treats as an orphan.
  remove_file(r.tombstone ? tombstone_file(r.id, r.generation) : chunk_file(r.id, r.generation), false);
}

void ChunkStore::set_config(const std::string& key, const std::string& value) {
  if (key.empty() || key.find_first_of(" \t\r\n") != std::string::npos)
    fail("chunk store: config key '", key, "' must be non-empty and free of blanks");
  if (value.find_first_of("\r\n") != std::string::npos)
    fail("chunk store: config value of '", key, "' must not contain line breaks");
  refuse_write("change its settings");
  std::lock_guard lock(mutex_);
  auto& v = manifest_.config[key];
  if (v != value) {
    v = value;
    dirty_ = true;
  }
}

std::optional<std::string> ChunkStore::config_value(const std::string& key) const {
  std::lock_guard lock(mutex_);
  auto it = manifest_.config.find(key);
  if (it == manifest_.config.end()) return std::nullopt;
  return it->second;
}

void ChunkStore::commit() {
  std::lock_guard commit_lock(commit_mutex_);
  Manifest snapshot;
  std::vector<std::pair<ChunkId, uint64_t>> to_sync;
  {
    std::lock_guard lock(mutex_);
    if (snapshot_) fail(folder_.string(), ": commit while a snapshot is pending (commit or abandon it first)");
    if (!dirty_) return;
    refuse_write("commit");
    snapshot = manifest_;
    snapshot.next_generation = writing_.empty() ? next_generation_ : *writing_.begin();
    to_sync = start_commit_locked(snapshot);
    dirty_ = false;
  }
  try {
    commit_manifest(snapshot, to_sync);
  } catch (...) {
    std::lock_guard lock(mutex_);
    dirty_ = true;
    throw;
  }
}

std::vector<std::pair<ChunkId, uint64_t>> ChunkStore::start_commit_locked(const Manifest& snapshot) {
  std::vector<std::pair<ChunkId, uint64_t>> to_sync;
  for (const auto& [id, e] : snapshot.chunks)
    if (unsynced_.erase({id, e.generation})) to_sync.emplace_back(id, e.generation);
  committing_ = true;  // from here until the manifest is written no superseded file is deleted
  return to_sync;
}

void ChunkStore::commit_manifest(const Manifest& snapshot, const std::vector<std::pair<ChunkId, uint64_t>>& to_sync) {
  try {
    ScopedTimer t(counters_.barrier_ns);
    if (config_.durable) {
      // Content first, then the names, then the manifest that names them: power loss at any
      // point leaves the previous manifest with all its files, or the new one with all of its.
      std::vector<fs::path> files;
      for (const auto& [id, g] : to_sync) files.push_back(chunk_file(id, g));
      sync_files(files);
      if (!to_sync.empty()) sync_directory(chunk_dir_);
      counters_.synced_files += to_sync.size();
    }
    snapshot.write(manifest_path(), config_.durable);
  } catch (...) {
    std::lock_guard lock(mutex_);
    committing_ = false;
    for (const auto& f : to_sync)
      if (is_current_locked(f.first, f.second) || is_held(f.first, f.second)) unsynced_.insert(f);
    throw;
  }
  counters_.barriers++;
  std::vector<Retired> doomed;
  {
    std::lock_guard lock(mutex_);
    committing_ = false;
    // What the previous manifest named may be in a reader's hands (it read that manifest and is
    // opening the files): it goes at the next commit. The rest no reader could know of.
    for (const Retired& r : deferred_)
      (deletable_after(r, snapshot) ? doomed : retired_).push_back(r);
    deferred_.clear();
    std::erase_if(retired_, [&](const Retired& r) {
      if (!deletable_after(r, snapshot)) return false;
      (!r.tombstone && is_committed(r.id, r.generation) ? deferred_ : doomed).push_back(r);
      return true;
    });
    committed_ = snapshot.chunks;
  }
  for (const Retired& r : doomed) delete_file(r);
}

void ChunkStore::delete_deferred() {
  std::vector<Retired> doomed;
  {
    std::lock_guard lock(mutex_);
    doomed.swap(deferred_);
  }
  for (const Retired& r : doomed) delete_file(r);
}

bool ChunkStore::is_current_locked(ChunkId id, uint64_t generation) const {
  auto it = manifest_.chunks.find(id);
  return it != manifest_.chunks.end() && it->second.generation == generation;
}

}  // namespace chungs
