// Chunk and keyframe files whose headers declare more than the file can hold are refused, naming the
// file and the field, before anything is allocated for it (a chunk declaring 2^28 Gaussians with a
// tiny payload once took 11.5 GB in `export`, a 32768x32768 keyframe 8.6 GB on `run --resume`). The
// headers carry valid checksums: a checksum proves nothing about a file someone wrote on purpose.
// The readers run in a child with a bounded address space, so one that trusts the header fails there
// with std::bad_alloc instead of the test machine.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <fstream>

#include "chungs/store/checksum.hpp"
#include "chungs/store/chunk_codec.hpp"
#include "chungs/store/chunk_file.hpp"
#include "chungs/store/keyframe_file.hpp"
#include "memory_limit.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

constexpr size_t kChildMemory = size_t(64) << 20;  // far below what the headers declare

// The start of a zstd frame: magic, a descriptor (single segment, 8-byte content size) and the
// content size it declares; no blocks follow.
std::string zstd_frame_header(uint64_t content_size) {
  std::string s("\x28\xb5\x2f\xfd\xe0", 5);
  s.append(reinterpret_cast<const char*>(&content_size), 8);  // little-endian, as the build machine
  return s;
}

template <class Header>
void write_file(const fs::path& file, Header h, const std::string& payload) {
  h.payload_bytes = payload.size();
  h.payload_checksum = xxh64(payload.data(), payload.size());
  h.header_checksum = xxh64(&h, offsetof(Header, header_checksum));
  std::ofstream out(file, std::ios::binary);
  out.write(reinterpret_cast<const char*>(&h), sizeof h);
  out << payload;
}

// chunk_file.hpp's header layout.
struct ChunkHeader {
  char magic[8];
  uint32_t version, header_size;
  uint64_t chunk_id, count;
  uint32_t sh_degree, flags;
  uint64_t payload_bytes, raw_bytes, payload_checksum, header_checksum;
};
static_assert(sizeof(ChunkHeader) == 72);

void write_chunk(const fs::path& file, uint64_t count, uint32_t flags) {
  ChunkHeader h{};
  std::memcpy(h.magic, "CHGSCHNK", 8);
  h.version = kChunkFormatVersion;
  h.header_size = sizeof h;
  h.count = count;
  h.sh_degree = 3;
  h.flags = flags;
  h.raw_bytes = chunk_payload_bytes(count, flags);
  write_file(file, h, zstd_frame_header(h.raw_bytes));
}

// keyframe_file.hpp's header layout.
struct KeyframeHeader {
  char magic[8];
  uint32_t version, header_size;
  uint64_t id;
  int32_t color_w, color_h, color_c, depth_w, depth_h, depth_c;
  uint32_t flags, reserved;
  uint64_t payload_bytes, raw_bytes, payload_checksum, header_checksum;
};
static_assert(sizeof(KeyframeHeader) == 88);

void write_keyframe(const fs::path& file, int32_t side) {
  KeyframeHeader h{};
  std::memcpy(h.magic, "CHGSKFRM", 8);
  h.version = kKeyframeFormatVersion;
  h.header_size = sizeof h;
  h.id = 7;
  h.color_w = h.color_h = h.depth_w = h.depth_h = side;
  h.color_c = 4;
  h.depth_c = 1;
  h.flags = 1;  // zstd
  h.raw_bytes = uint64_t(side) * uint64_t(side) * 8;
  write_file(file, h, zstd_frame_header(h.raw_bytes));
}

void expect_refused(const fs::path& file, const std::function<void()>& read,
                    const std::vector<std::string>& parts) {
  const auto r = test::run_with_memory_limit(kChildMemory, read);
  EXPECT_EQ(r.outcome, "error") << r.describe();
  EXPECT_NE(r.message.find(file.filename().string()), std::string::npos) << r.message;
  for (const auto& p : parts)
    EXPECT_NE(r.message.find(p), std::string::npos) << "'" << p << "' not in " << r.message;
}

TEST(DeclaredSize, ChunkCountBeyondThePayloadOrAnyChunkIsRefusedBeforeAllocating) {
  test::TempDir dir;
  const uint32_t zstd = kChunkFlagZstd | kChunkFlagShuffled;
  for (uint32_t flags : {zstd, zstd | kChunkFlagsHalf}) {
    SCOPED_TRACE(flags);
    const fs::path file = dir / "a.chunk";
    auto read = [&] {
      GaussianBlock b;
      read_chunk_file(file, b);
    };
    write_chunk(file, uint64_t(1) << 28, flags);  // more than any chunk holds
    expect_refused(file, read, {"268435456"});
    EXPECT_THROW(read_chunk_header(file), Error);
    write_chunk(file, uint64_t(1) << 20, flags);  // a plausible count, but not from 13 bytes
    expect_refused(file, read, {"1048576 Gaussians", "13 bytes"});
    EXPECT_THROW(read_chunk_header(file), Error);
  }
}

TEST(DeclaredSize, KeyframeImagesBeyondThePayloadOrAnyImageAreRefusedBeforeAllocating) {
  test::TempDir dir;
  const fs::path file = dir / "7.keyframe";
  auto read = [&] {
    KeyframeImages im;
    read_keyframe_file(file, im);
  };
  write_keyframe(file, 32768);  // more than any image we read
  expect_refused(file, read, {"32768 x 32768"});
  write_keyframe(file, 4096);  // a plausible size, but not from 13 bytes
  expect_refused(file, read, {"4096 x 4096", "13 bytes"});
}

}  // namespace
