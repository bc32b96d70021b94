// What makes a folder a map to read: its manifest (chunk_store.hpp). Readers refuse a folder without
// one; where the map's keyframe list is there but its manifest is not (lost, or deleted after it read
// back corrupt), the error says that a writer rebuilds it.
#pragma once
#include <filesystem>

namespace chungs {

// Throws Error naming the folder when it holds no manifest.txt.
void require_map_manifest(const std::filesystem::path& folder);

}  // namespace chungs
