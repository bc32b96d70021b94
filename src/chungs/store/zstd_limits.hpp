// What a zstd payload can decompress to, checked before anything is allocated for it: a size in a
// header is only a claim (its checksum proves nothing about a file written on purpose), and a few
// bytes must not make a reader allocate gigabytes. Chunk and keyframe files share these checks.
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>

namespace chungs {

// zstd expands at most 32768:1: its densest block, run-length, spends 4 bytes on 128 KiB.
constexpr uint64_t kMaxZstdExpansion = 32768;

// Throws "FILE: WHAT in the header: N bytes, more than a zstd payload of M bytes holds" when
// `raw_bytes` exceed what `payload_bytes` can expand to; `what` names the fields the size comes from.
void check_zstd_expansion(const std::filesystem::path& file, const std::string& what, uint64_t raw_bytes,
                          uint64_t payload_bytes);
// Throws naming the file unless `payload` starts a zstd frame whose header declares `raw_bytes` as
// its content size, or declares none.
void check_zstd_content_size(const std::filesystem::path& file, const void* payload, size_t payload_bytes,
                             uint64_t raw_bytes);

}  // namespace chungs
