// Names of the files in a map's chunk folder: "<id>-<generation>.chunk" (16 hex digits each) for
// chunk content, "<id>-<generation>.removed" (empty) for a removal not yet committed, and the
// version 1 layout's "<id>.chunk", which stands for generation 0.
#pragma once
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "chungs/store/chunk_id.hpp"

namespace chungs {

struct ChunkFileName {
  ChunkId id = 0;
  uint64_t generation = 0;
  bool tombstone = false;
};

std::string chunk_file_name(ChunkId id, uint64_t generation, bool tombstone);
// nullopt for anything else (temporaries, foreign files).
std::optional<ChunkFileName> parse_chunk_file_name(const std::string& name);
// Whether a map's chunk folder holds any chunk content file (false when it is missing).
bool holds_chunk_files(const std::filesystem::path& chunk_dir);

}  // namespace chungs
