#include "chungs/store/chunk_file_name.hpp"

#include <cinttypes>
#include <cstdio>

namespace chungs {

namespace {
constexpr const char* kChunkExt = ".chunk";
constexpr const char* kTombstoneExt = ".removed";

std::optional<uint64_t> parse_hex16(const std::string& s, size_t at) {
  if (s.size() < at + 16) return std::nullopt;
  uint64_t v = 0;
  for (size_t i = at; i < at + 16; ++i) {
    const char c = s[i];
    const int d = c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
    if (d < 0) return std::nullopt;
    v = v << 4 | uint64_t(d);
  }
  return v;
}
}  // namespace

std::string chunk_file_name(ChunkId id, uint64_t generation, bool tombstone) {
  char name[64];
  if (generation == 0 && !tombstone)
    std::snprintf(name, sizeof name, "%016" PRIx64 "%s", id, kChunkExt);
  else
    std::snprintf(name, sizeof name, "%016" PRIx64 "-%016" PRIx64 "%s", id, generation,
                  tombstone ? kTombstoneExt : kChunkExt);
  return name;
}

std::optional<ChunkFileName> parse_chunk_file_name(const std::string& name) {
  const auto id = parse_hex16(name, 0);
  if (!id) return std::nullopt;
  const std::string rest = name.substr(16);
  if (rest == kChunkExt) return ChunkFileName{*id, 0, false};
  if (rest.size() < 17 || rest[0] != '-') return std::nullopt;
  const auto generation = parse_hex16(rest, 1);
  if (!generation || *generation == 0) return std::nullopt;
  const std::string ext = rest.substr(17);
  if (ext == kChunkExt) return ChunkFileName{*id, *generation, false};
  if (ext == kTombstoneExt) return ChunkFileName{*id, *generation, true};
  return std::nullopt;
}

bool holds_chunk_files(const std::filesystem::path& chunk_dir) {
  std::error_code ec;
  for (std::filesystem::directory_iterator it(chunk_dir, ec), end; !ec && it != end; it.increment(ec))
    if (const auto name = parse_chunk_file_name(it->path().filename().string()); name && !name->tombstone) return true;
  return false;
}

}  // namespace chungs
