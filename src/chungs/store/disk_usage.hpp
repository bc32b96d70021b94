// How much disk a map folder takes: chunk files, manifest, keyframes, everything below it.
#pragma once
#include <cstdint>
#include <filesystem>

namespace chungs {

struct DiskUsage {
  uint64_t files = 0;
  uint64_t bytes = 0;            // sum of file sizes
  uint64_t allocated_bytes = 0;  // blocks the filesystem allocated (st_blocks), what df sees
};

// Walks `folder` recursively (links are not followed). Throws Error naming the folder when it
// cannot be listed; files that vanish during the walk (a concurrent writer) are skipped.
DiskUsage disk_usage(const std::filesystem::path& folder);

}  // namespace chungs
