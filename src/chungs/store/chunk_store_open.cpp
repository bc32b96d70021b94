// Opening a map folder: choosing, per chunk, which of its files holds the truth (see the rules in
// chunk_store.hpp) and listing the rest for deletion once the repaired manifest is durable.
#include <map>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/store/chunk_file_name.hpp"
#include "chungs/store/chunk_store.hpp"

namespace chungs {

namespace fs = std::filesystem;

void ChunkStore::reconcile(bool have_manifest) {
  // id -> generation -> tombstone?
  std::map<ChunkId, std::map<uint64_t, bool>> found;
  uint64_t max_generation = manifest_.next_generation;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(chunk_dir_, ec)) {
    const auto name = parse_chunk_file_name(e.path().filename().string());
    if (!name || !e.is_regular_file()) continue;
    found[name->id][name->generation] = name->tombstone;
    max_generation = std::max(max_generation, name->generation + 1);
  }
  if (ec) fail(chunk_dir_.string(), ": cannot list chunk files: ", ec.message());
  for (const auto& [id, entry] : manifest_.chunks) {
    found[id];  // visit manifest entries whose files are gone too
    max_generation = std::max(max_generation, entry.generation + 1);
  }
  next_generation_ = std::max<uint64_t>(max_generation, 1);
  // Files below the watermark that the manifest does not name were obsolete when it was written.
  const uint64_t watermark = manifest_.next_generation;

  auto entry_of = [](const ChunkFileInfo& info, uint64_t generation) {
    return ManifestEntry{info.count, info.file_bytes, info.payload_checksum, generation};
  };
  std::map<ChunkId, ManifestEntry> chosen;
  std::vector<fs::path> missing;  // files the manifest names that are gone, their chunks dropped
  for (auto& [id, generations] : found) {
    auto listed = manifest_.chunks.find(id);
    const ManifestEntry* named = listed == manifest_.chunks.end() ? nullptr : &listed->second;
    bool decided = false;
    std::optional<uint64_t> keep;
    std::vector<std::pair<uint64_t, bool>> newer;  // newest first
    for (auto g = generations.rbegin(); config_.adopt_uncommitted && g != generations.rend(); ++g) {
      if (g->first < watermark || (named && g->first <= named->generation)) break;
      newer.push_back(*g);
    }
    for (const auto& [gen, tombstone] : newer) {
      if (tombstone) {  // a removal after the manifest was written
        decided = true;
        break;
      }
      // Newer than the manifest: possibly never flushed, so it must read back whole.
      const fs::path file = chunk_file(id, gen);
      GaussianBlock scratch;
      ChunkFileInfo info;
      try {
        info = read_chunk_file(file, scratch);
      } catch (const Error& e) {
        log::warn("ignoring a chunk file written after the last commit that does not read back: ", e.what());
        remove_file(file, false);
        ++report_.files_rejected;
        generations.erase(gen);
        continue;
      }
      if (info.id != id)
        fail(file.string(), ": header names ", chunk_name(info.id), " but the file name names ",
             chunk_name(id));
      chosen[id] = entry_of(info, gen);
      keep = gen;
      decided = true;
      break;
    }
    if (!decided && named && generations.count(named->generation) && !generations[named->generation]) {
      const fs::path file = chunk_file(id, named->generation);
      ChunkFileInfo info;
      if (config_.verify_on_open) {
        GaussianBlock scratch;
        info = read_chunk_file(file, scratch);
      } else {
        info = read_chunk_header(file);
      }
      if (info.id != id)
        fail(file.string(), ": header names ", chunk_name(info.id), " but the file name names ",
             chunk_name(id));
      chosen[id] = entry_of(info, named->generation);
      keep = named->generation;
    }
    for (const auto& [gen, tombstone] : generations) {
      if (keep && gen == *keep) continue;
      // An orphan may be torn (power loss), but one that names another chunk was misplaced.
      std::optional<ChunkFileInfo> info;
      if (!tombstone) try {
          info = read_chunk_header(chunk_file(id, gen));
        } catch (const Error&) {
        }
      if (info && info->id != id)
        fail(chunk_file(id, gen).string(), ": header names ", chunk_name(info->id),
             " but the file name names ", chunk_name(id));
      retired_.push_back({id, gen, tombstone, true});
      ++report_.orphans;
    }
    if (keep && config_.durable && (!named || *keep != named->generation)) unsynced_.insert({id, *keep});
    if (named) committed_[id] = *named;
    const auto c = chosen.find(id);
    if (!named && c != chosen.end()) {
      ++report_.entries_adopted;
    } else if (named && c == chosen.end()) {
      ++report_.entries_dropped;
      // Gone without a removal after the commit (a tombstone) to explain it.
      if (!decided && !generations.count(named->generation)) missing.push_back(chunk_file(id, named->generation));
    } else if (named && !(c->second == *named)) {
      ++report_.entries_updated;
    }
  }
  // Damage rather than an interrupted session (a committed file goes only after a commit that no
  // longer names it). Dropping the chunk would lose its Gaussians, and the repair would delete its
  // older files with them, which a rebuild from the chunk files can still use: refused, as the readers
  // refuse it, before anything in the folder changes.
  if (!missing.empty())
    fail(missing.front().string(), ": listed in ", manifest_path().string(), " but missing",
         missing.size() > 1 ? cat(" (and ", missing.size() - 1, " more chunk files)") : std::string(),
         "; the map is left as it is (to go on without them, delete manifest.txt, and `run --resume` rebuilds "
         "it from the chunk files that are there)");
  manifest_.chunks = std::move(chosen);
  if (have_manifest && (report_.repaired() || report_.files_rejected))
    log::warn(folder_.string(), ": manifest was behind the chunk files (interrupted session): adopted ",
              report_.entries_adopted, ", updated ", report_.entries_updated, ", dropped ",
              report_.entries_dropped, " entries; ", report_.files_rejected,
              " unreadable newer files ignored");
}

}  // namespace chungs
