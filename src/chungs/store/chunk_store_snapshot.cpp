// Snapshots of the map, committed while the live map goes on changing (chunk_store.hpp).
#include "chungs/common/error.hpp"
#include "chungs/store/chunk_store.hpp"

namespace chungs {

void ChunkStore::begin_snapshot() {
  refuse_write("begin a snapshot");
  std::lock_guard lock(mutex_);
  if (snapshot_) fail(folder_.string(), ": a snapshot is already pending");
  snapshot_ = manifest_;
  // Later generations were written after the moment the snapshot shows.
  snapshot_->next_generation = writing_.empty() ? next_generation_ : *writing_.begin();
  held_.clear();
  for (const auto& [id, e] : snapshot_->chunks) held_.insert({id, e.generation});
}

bool ChunkStore::snapshot_pending() const {
  std::lock_guard lock(mutex_);
  return snapshot_.has_value();
}

void ChunkStore::save_to_snapshot(ChunkId id, const GaussianBlock& block) {
  if (block.size() > 0) block.validate(cat(folder_.string(), ": ", chunk_name(id)).c_str());
  save_arrays_to_snapshot(id, block_arrays(block));
}

void ChunkStore::save_arrays_to_snapshot(ChunkId id, const ConstBlockArrays& block) {
  auto no_snapshot = [&] { fail(folder_.string(), ": save_to_snapshot of ", chunk_name(id), " without a snapshot"); };
  if (!snapshot_pending()) no_snapshot();
  std::optional<std::pair<uint64_t, ChunkFileInfo>> written;
  if (block.count > 0) written = write_generation(id, block);
  std::lock_guard lock(mutex_);
  if (!snapshot_) {  // abandoned while this one was written (another writer failed)
    if (written) delete_file({id, written->first, false});
    no_snapshot();
  }
  if (!written) {
    snapshot_->chunks.erase(id);
    return;
  }
  const auto& [generation, info] = *written;
  held_.insert({id, generation});
  if (config_.durable) unsynced_.insert({id, generation});
  snapshot_->chunks[id] = {info.count, info.file_bytes, info.payload_checksum, generation};
}

void ChunkStore::commit_snapshot() {
  std::lock_guard commit_lock(commit_mutex_);
  Manifest snapshot;
  std::vector<std::pair<ChunkId, uint64_t>> to_sync;
  {
    std::lock_guard lock(mutex_);
    if (!snapshot_) fail(folder_.string(), ": commit_snapshot without a snapshot");
    snapshot = *snapshot_;
    to_sync = start_commit_locked(snapshot);
  }
  commit_manifest(snapshot, to_sync);
  std::lock_guard lock(mutex_);
  // Files only the snapshot names go once a later commit no longer names them.
  for (const auto& [id, e] : snapshot.chunks)
    if (!is_current_locked(id, e.generation)) retired_.push_back({id, e.generation, false});
  snapshot_.reset();
  held_.clear();
  dirty_ = true;  // the live map is not what the disk now names
}

void ChunkStore::abandon_snapshot() {
  std::lock_guard lock(mutex_);
  if (!snapshot_) return;
  for (const auto& [id, e] : snapshot_->chunks)
    if (!is_current_locked(id, e.generation) && !is_committed(id, e.generation)) {
      unsynced_.erase({id, e.generation});
      retired_.push_back({id, e.generation, false});
    }
  snapshot_.reset();
  held_.clear();
}

bool ChunkStore::adopt_committed(ChunkId id) {
  std::optional<Retired> doomed;
  {
    std::lock_guard lock(mutex_);
    if (snapshot_ || committing_) return false;
    const auto committed = committed_.find(id);
    if (committed == committed_.end()) return false;
    const ManifestEntry entry = committed->second;
    const auto live = manifest_.chunks.find(id);
    if (live != manifest_.chunks.end() && live->second.generation == entry.generation) return false;
    // The committed file waits among the retired for a commit that no longer names it: it is live now.
    std::erase_if(retired_,
                  [&](const Retired& r) { return !r.tombstone && r.id == id && r.generation == entry.generation; });
    if (live != manifest_.chunks.end()) doomed = retire({id, live->second.generation, false});
    manifest_.chunks[id] = entry;
    dirty_ = true;
  }
  if (doomed) delete_file(*doomed);
  return true;
}

}  // namespace chungs
