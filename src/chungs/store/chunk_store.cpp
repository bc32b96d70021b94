#include "chungs/store/chunk_store.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {
constexpr const char* kChunkExt = ".chunk";

// "0123456789abcdef.chunk" -> id; nullopt for anything else (temporaries, foreign files).
std::optional<ChunkId> id_from_name(const std::string& name) {
  if (name.size() != 16 + std::strlen(kChunkExt) || name.substr(16) != kChunkExt) return std::nullopt;
  ChunkId id = 0;
  for (int i = 0; i < 16; ++i) {
    const char c = name[i];
    const int d = c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
    if (d < 0) return std::nullopt;
    id = id << 4 | uint64_t(d);
  }
  return id;
}
}  // namespace

ChunkStore::ChunkStore(fs::path folder, const ChunkStoreConfig& config)
    : folder_(std::move(folder)), chunk_dir_(folder_ / "chunks"), config_(config),
      chunk_size_(config.chunk_size), sh_degree_(config.sh_degree) {
  if (!(chunk_size_ > 0)) fail("chunk store: chunk size must be positive, got ", chunk_size_);
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
      fail(e.what(), " (delete the manifest to rebuild it from the chunk files)");
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
  if (!have_manifest || report_.repaired()) {
    dirty_ = true;
    commit();
  }
}

ChunkStore::~ChunkStore() {
  try {
    commit();
  } catch (const std::exception& e) {
    log::error(folder_.string(), ": could not write the manifest on close: ", e.what());
  }
}

void ChunkStore::reconcile(bool have_manifest) {
  std::map<ChunkId, ManifestEntry> found;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(chunk_dir_, ec)) {
    const auto id = id_from_name(e.path().filename().string());
    if (!id || !e.is_regular_file()) continue;
    ChunkFileInfo info;
    if (config_.verify_on_open) {
      GaussianBlock scratch;
      info = read_chunk_file(e.path(), scratch);
    } else {
      info = read_chunk_header(e.path());
    }
    if (info.id != *id)
      fail(e.path().string(), ": header names ", chunk_name(info.id), " but the file name names ", chunk_name(*id));
    found[*id] = {info.count, info.file_bytes, info.payload_checksum};
  }
  if (ec) fail(chunk_dir_.string(), ": cannot list chunk files: ", ec.message());
  for (const auto& [id, entry] : manifest_.chunks)
    if (!found.count(id)) ++report_.entries_dropped;
  for (const auto& [id, entry] : found) {
    auto it = manifest_.chunks.find(id);
    if (it == manifest_.chunks.end())
      ++report_.entries_adopted;
    else if (!(it->second == entry))
      ++report_.entries_updated;
  }
  manifest_.chunks = std::move(found);
  if (have_manifest && report_.repaired())
    log::warn(folder_.string(), ": manifest was behind the chunk files (interrupted session): adopted ",
              report_.entries_adopted, ", updated ", report_.entries_updated, ", dropped ",
              report_.entries_dropped, " entries");
}

fs::path ChunkStore::chunk_path(ChunkId id) const {
  char name[40];
  std::snprintf(name, sizeof name, "%016" PRIx64 "%s", id, kChunkExt);
  return chunk_dir_ / name;
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
  if (!contains(id)) fail(folder_.string(), ": ", chunk_name(id), " is not in this map");
  const fs::path file = chunk_path(id);
  GaussianBlock b;
  ChunkFileInfo info;
  {
    ScopedTimer t(counters_.load_ns);
    info = read_chunk_file(file, b);
  }
  if (info.id != id) fail(file.string(), ": header names ", chunk_name(info.id), ", expected ", chunk_name(id));
  counters_.loads++;
  counters_.bytes_read += info.file_bytes;
  return b;
}

void ChunkStore::save(ChunkId id, const GaussianBlock& block) {
  if (block.size() == 0) {
    remove(id);
    return;
  }
  chunk_coord(id);  // rejects ids that no coordinate produces
  const ChunkWriteOptions opt{config_.compress, config_.zstd_level, config_.shuffle, config_.durable};
  const fs::path file = chunk_path(id);
  ChunkFileInfo info;
  {
    ScopedTimer t(counters_.save_ns);
    info = write_chunk_file(file, id, block, opt);
  }
  counters_.saves++;
  counters_.bytes_written += info.file_bytes;
  std::lock_guard lock(mutex_);
  manifest_.chunks[id] = {info.count, info.file_bytes, info.payload_checksum};
  dirty_ = true;
}

void ChunkStore::remove(ChunkId id) {
  remove_file(chunk_path(id), config_.durable);
  counters_.removes++;
  std::lock_guard lock(mutex_);
  if (manifest_.chunks.erase(id)) dirty_ = true;
}

void ChunkStore::set_config(const std::string& key, const std::string& value) {
  if (key.empty() || key.find_first_of(" \t\r\n") != std::string::npos)
    fail("chunk store: config key '", key, "' must be non-empty and free of blanks");
  if (value.find_first_of("\r\n") != std::string::npos)
    fail("chunk store: config value of '", key, "' must not contain line breaks");
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
  {
    std::lock_guard lock(mutex_);
    if (!dirty_) return;
    snapshot = manifest_;
    dirty_ = false;
  }
  try {
    snapshot.write(manifest_path(), config_.durable);
  } catch (...) {
    std::lock_guard lock(mutex_);
    dirty_ = true;
    throw;
  }
}

}  // namespace chungs

