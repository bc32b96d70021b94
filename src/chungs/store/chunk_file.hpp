// One chunk's Gaussians (parameters, Adam moments, bookkeeping) as one file.
//
// Layout, little-endian: a 72-byte header
//   magic "CHGSCHNK" | version u32 | header size u32 | chunk id u64 | count u64 | SH degree u32 |
//   flags u32 | payload bytes u64 | raw payload bytes u64 | payload XXH64 u64 | header XXH64 u64
// then the payload: the GaussianBlock arrays in a fixed order (chunk_codec.hpp), each as raw
// 4-byte elements or, with the half flags (version 2), Adam moments and/or SH rest coefficients
// as a scale plus binary16 values; optionally byte-shuffled (all first bytes of the array's
// elements, then all second bytes, ...) and zstd-compressed as one stream. The payload checksum covers the
// stored (possibly compressed) bytes, so corruption is caught before decompression; the header has its own
// checksum.
#pragma once
#include <cstdint>
#include <filesystem>
#include <functional>

#include "chungs/gaussians/block_arrays.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/chunk_id.hpp"

namespace chungs {

// Version 2 adds the half-precision flags (chunk_codec.hpp); version 1 files read unchanged.
constexpr uint32_t kChunkFormatVersion = 2;
constexpr uint32_t kChunkFlagZstd = 1u << 0;
constexpr uint32_t kChunkFlagShuffled = 1u << 1;
constexpr uint32_t kChunkFlagsHalf = (1u << 2) | (1u << 3);  // kChunkFlagHalfMoments | kChunkFlagHalfShRest
// At full precision: 3 x 59 floats (parameters and both Adam moments) + 4 bookkeeping words per
// Gaussian.
constexpr uint64_t kChunkBytesPerGaussian = 3 * kParamFloats * 4 + 4 * 4;
// 16.8 M Gaussians, 12 GB in memory: far above any chunk (a chunk must fit the residency budget to be
// trained, 1.5 M by default), and the most a header or a manifest may make a reader allocate.
constexpr uint64_t kMaxChunkGaussians = uint64_t(1) << 24;

struct ChunkWriteOptions {
  bool compress = false;  // zstd; pays off mostly on fresh Gaussians (zero SH, zero Adam state)
  int zstd_level = 1;
  bool shuffle = true;           // byte-shuffle before zstd: float exponents compress, mantissas barely
  bool durable = true;           // flush file and folder (survives power loss, not just a killed process)
  bool half_moments = false;     // Adam moments as binary16 (see chunk_codec.hpp)
  bool half_sh_rest = false;     // SH coefficients beyond DC as binary16
  bool start_writeback = false;  // without durable: start writing to disk now, do not wait
};

struct ChunkFileInfo {
  ChunkId id = 0;
  uint64_t count = 0;
  int sh_degree = 0;
  uint32_t flags = 0;
  uint64_t file_bytes = 0;
  uint64_t payload_checksum = 0;
};

// Writes crash-safely (temporary + flush + rename + folder flush); returns what a header read of
// the new file would. Throws Error naming the file on I/O failure and on an inconsistent block.
ChunkFileInfo write_chunk_file(const std::filesystem::path& file, ChunkId id, const GaussianBlock& block,
                               const ChunkWriteOptions& options);
// The same from arrays held elsewhere (their count and SH degree are the chunk's).
ChunkFileInfo write_chunk_file(const std::filesystem::path& file, ChunkId id, const ConstBlockArrays& block,
                               const ChunkWriteOptions& options);
// Checks magic, version, header checksum and file size, without reading the payload.
ChunkFileInfo read_chunk_header(const std::filesystem::path& file);
// Reads and verifies everything; `out` is replaced only on success. Every rejection names the file.
ChunkFileInfo read_chunk_file(const std::filesystem::path& file, GaussianBlock& out);
// The same from a file already open (read from its start; `file` names it in errors): a reader
// holds its chunk files open so that a writer deleting them cannot take them away mid-read.
ChunkFileInfo read_chunk_file(const FileDescriptor& fd, const std::filesystem::path& file, GaussianBlock& out);
// Where a chunk read goes: arrays for the header's count and SH degree, asked for once the header
// (and a compressed payload) checked out. Every value of them is overwritten.
using ChunkPlacer = std::function<BlockArrays(uint64_t count, int sh_degree)>;
ChunkFileInfo read_chunk_file(const FileDescriptor& fd, const std::filesystem::path& file, const ChunkPlacer& place);

}  // namespace chungs
