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

// Version 2 adds each chunk's file generation; version 1 manifests read as generation 0.
constexpr int kManifestVersion = 2;

struct ManifestEntry {
  uint64_t count = 0;       // Gaussians in the chunk
  uint64_t file_bytes = 0;  // size of its file
  uint64_t checksum = 0;    // the file's payload XXH64
  uint64_t generation = 0;  // which of the chunk's files holds it (see ChunkStore)

  bool operator==(const ManifestEntry&) const = default;
};

struct Manifest {
  double chunk_size = 10.0;
  int sh_degree = 3;
  // Every chunk file of a lower generation is either named here or obsolete, so after a crash
  // only files from this generation on can hold content newer than this manifest (0: unknown).
  uint64_t next_generation = 0;
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
