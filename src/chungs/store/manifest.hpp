// The map folder's manifest: chunk size, SH degree, the chunks with their Gaussian counts and file
// checksums, and free-form configuration entries that higher layers record (key value lines).
// It is a text file ending in a line with the entry count and the XXH64 of everything before it,
// written crash-safely, so a reader sees a whole manifest or rejects it, never half of one.
#pragma once
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "chungs/store/chunk_id.hpp"

namespace chungs {

constexpr int kManifestVersion = 1;

struct ManifestEntry {
  uint64_t count = 0;       // Gaussians in the chunk
  uint64_t file_bytes = 0;  // size of its file
  uint64_t checksum = 0;    // the file's payload XXH64

  bool operator==(const ManifestEntry&) const = default;
};

struct Manifest {
  double chunk_size = 10.0;
  int sh_degree = 3;
  std::map<std::string, std::string> config;  // keys without blanks, values without line breaks
  std::map<ChunkId, ManifestEntry> chunks;

  uint64_t total_gaussians() const;
  std::string serialize() const;  // throws on keys or values that would not read back
  // Throws Error "FILE:LINE: ..." on any malformed, truncated or corrupt manifest.
  static Manifest parse(const std::string& text, const std::filesystem::path& file);
  static Manifest read(const std::filesystem::path& file);
  void write(const std::filesystem::path& file, bool durable) const;
};

}  // namespace chungs
