#include <gtest/gtest.h>
#include <zstd.h>

#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/chunk_file.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
const ChunkId kId = chunk_id({3, -2, 17});

std::string error_of(const fs::path& file) {
  GaussianBlock b;
  try {
    read_chunk_file(file, b);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

void patch(const fs::path& file, size_t offset, std::vector<uint8_t> bytes) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(std::streamoff(offset));
  f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

void flip_byte(const fs::path& file, size_t offset) {
  auto bytes = read_whole_file(file);
  ASSERT_LT(offset, bytes.size());
  patch(file, offset, {uint8_t(bytes[offset] ^ 0x10)});
}

struct Mode {
  bool compress, shuffle;
};
}  // namespace

class ChunkFileModes : public ::testing::TestWithParam<Mode> {};

TEST_P(ChunkFileModes, RoundTripsEveryArrayBitExactly) {
  test::TempDir dir;
  const ChunkWriteOptions opt{GetParam().compress, 1, GetParam().shuffle, false};
  for (size_t n : {size_t(0), size_t(1), size_t(7), size_t(2500)}) {
    GaussianBlock b = test::random_block(n, n + 1, 30, -20, 170);
    b.sh_degree = int(n % 4);
    const fs::path f = dir / ("c" + std::to_string(n));
    const ChunkFileInfo w = write_chunk_file(f, kId, b, opt);
    EXPECT_EQ(w.file_bytes, fs::file_size(f));
    GaussianBlock r;
    const ChunkFileInfo info = read_chunk_file(f, r);
    EXPECT_EQ(info.id, kId);
    EXPECT_EQ(info.count, n);
    EXPECT_EQ(info.sh_degree, b.sh_degree);
    EXPECT_EQ(info.payload_checksum, w.payload_checksum);
    EXPECT_TRUE(test::same_bits(b, r)) << "n=" << n;
    const ChunkFileInfo h = read_chunk_header(f);
    EXPECT_EQ(h.count, n);
    EXPECT_EQ(h.file_bytes, w.file_bytes);
    if (!opt.compress) {
      EXPECT_EQ(w.file_bytes, 72 + n * kChunkBytesPerGaussian);
    }
  }
}

TEST_P(ChunkFileModes, RejectsAnyFlippedPayloadByteNamingTheFile) {
  test::TempDir dir;
  const fs::path f = dir / "chunk.bin";
  const GaussianBlock b = test::random_block(300, 5);
  write_chunk_file(f, kId, b, {GetParam().compress, 1, GetParam().shuffle, false});
  const size_t size = fs::file_size(f);
  for (size_t off : {size_t(72), size_t(73), size / 2, size - 1}) {
    write_chunk_file(f, kId, b, {GetParam().compress, 1, GetParam().shuffle, false});
    flip_byte(f, off);
    const std::string e = error_of(f);
    EXPECT_NE(e.find("checksum"), std::string::npos) << "offset " << off << ": " << e;
    EXPECT_NE(e.find(f.string()), std::string::npos) << e;
  }
}

INSTANTIATE_TEST_SUITE_P(ChunkFile, ChunkFileModes,
                         ::testing::Values(Mode{false, false}, Mode{true, false}, Mode{true, true}),
                         [](const auto& info) {
                           return std::string(info.param.compress ? "Zstd" : "Raw") +
                                  (info.param.compress && info.param.shuffle ? "Shuffled" : "");
                         });

// A writer buffers small pieces and sends arrays of 256 KB or more straight to the file; such an array
// must not overtake what is buffered. Sizes where an array first goes straight through after others
// were buffered: float32 SH at 1,366-2,259 Gaussians (and 2,500 beyond the window), half-precision
// files' bookkeeping words at 65,536 and more.
TEST(ChunkFile, ArraysThatGoStraightToTheFileKeepTheirPlace) {
  test::TempDir dir;
  struct Case {
    size_t n;
    bool half;
  };
  for (const Case c : {Case{1366, false}, Case{2048, false}, Case{2259, false}, Case{2500, false}, Case{70000, true}}) {
    const GaussianBlock b = test::random_block(c.n, uint32_t(c.n), 30, -20, 170);
    for (int mode = 0; mode < 3; ++mode) {  // uncompressed, zstd, zstd with the byte shuffle
      const fs::path f = dir / "c.chunk";
      write_chunk_file(f, kId, b, {mode > 0, 1, mode == 2, false, c.half, c.half});
      GaussianBlock r;
      ASSERT_NO_THROW(read_chunk_file(f, r)) << c.n << " Gaussians, mode " << mode;
      if (!c.half) {
        EXPECT_TRUE(test::same_bits(b, r)) << c.n << " Gaussians, mode " << mode;
      } else {  // what stays float32 comes back exactly
        EXPECT_EQ(r.params.mean, b.params.mean) << mode;
        EXPECT_EQ(r.params.rotation, b.params.rotation) << mode;
        EXPECT_EQ(r.adam_steps, b.adam_steps) << mode;
        EXPECT_EQ(r.lr_position_factor, b.lr_position_factor) << mode;
      }
    }
  }
}

// The format of compressed files, restated from chunk_codec.hpp: the zstd content is each stored array
// of the uncompressed payload byte-shuffled by its elements (4 bytes; 2 for a half array, whose scale
// counts as its first two elements). Writers that shuffle a piece at a time must make exactly this.
TEST(ChunkFile, ZstdContentIsEachStoredArrayShuffledByItsElements) {
  test::TempDir dir;
  const size_t n = 2500;  // over a piece of 2,048 Gaussians
  const GaussianBlock b = test::random_block(n, 11, 30, -20, 170);
  for (const bool half : {false, true}) {
    write_chunk_file(dir / "raw", kId, b, {false, 1, false, false, half, half});
    write_chunk_file(dir / "z", kId, b, {true, 1, true, false, half, half});
    const std::vector<uint8_t> raw = read_whole_file(dir / "raw"), z = read_whole_file(dir / "z");
    const std::vector<uint8_t> payload(raw.begin() + 72, raw.end());
    std::vector<uint8_t> content(payload.size());
    ASSERT_EQ(ZSTD_decompress(content.data(), content.size(), z.data() + 72, z.size() - 72), payload.size());
    std::vector<uint8_t> expect;
    size_t at = 0;
    auto shuffled = [&](size_t bytes, size_t w) {
      for (size_t k = 0; k < w; ++k)
        for (size_t i = 0; i < bytes / w; ++i) expect.push_back(payload[at + w * i + k]);
      at += bytes;
    };
    for (int a = 0; a < kBlockArrays; ++a) {
      const size_t width = size_t(kBlockArrayWidths[size_t(a)]);
      const int group = a < kBlockFirstWord ? a / kBlockArraysPerGroup : -1;
      if (half && (group == 1 || group == 2)) {
        shuffled(4 + 2 * width * n, 2);
      } else if (half && group == 0 && a % kBlockArraysPerGroup == kBlockGroupSh) {
        shuffled(4 * 3 * n, 4);
        shuffled(4 + 2 * (width - 3) * n, 2);
      } else {
        shuffled(4 * width * n, 4);
      }
    }
    ASSERT_EQ(at, payload.size()) << half;
    EXPECT_TRUE(content == expect) << (half ? "half precision" : "float32");
  }
}

TEST(ChunkFile, CompressionShrinksFreshGaussians) {
  test::TempDir dir;
  GaussianBlock b = test::random_block(2000, 9);
  // Fresh Gaussians: no higher-order SH and no optimiser history yet.
  for (size_t i = 0; i < b.size(); ++i)
    for (int k = 3; k < kShFloats; ++k) b.params.sh[size_t(kShFloats) * i + k] = 0;
  b.adam_m.resize(0), b.adam_v.resize(0), b.adam_m.resize(b.size()), b.adam_v.resize(b.size());
  const auto raw = write_chunk_file(dir / "raw", kId, b, {false, 1, false, false});
  const auto z = write_chunk_file(dir / "z", kId, b, {true, 1, true, false});
  EXPECT_LT(z.file_bytes * 4, raw.file_bytes);
}

TEST(ChunkFile, RejectsBadMagic) {
  test::TempDir dir;
  const fs::path f = dir / "x.chunk";
  write_chunk_file(f, kId, test::random_block(4, 1), {false, 1, false, false});
  patch(f, 0, {'N', 'O', 'P', 'E'});
  EXPECT_NE(error_of(f).find("bad magic"), std::string::npos) << error_of(f);
}

TEST(ChunkFile, RejectsUnknownVersion) {
  test::TempDir dir;
  const fs::path f = dir / "x.chunk";
  write_chunk_file(f, kId, test::random_block(4, 1), {false, 1, false, false});
  patch(f, 8, {99, 0, 0, 0});
  EXPECT_NE(error_of(f).find("version 99"), std::string::npos) << error_of(f);
}

TEST(ChunkFile, RejectsCorruptHeader) {
  test::TempDir dir;
  const fs::path f = dir / "x.chunk";
  write_chunk_file(f, kId, test::random_block(4, 1), {false, 1, false, false});
  flip_byte(f, 24);  // inside the count
  EXPECT_NE(error_of(f).find("header checksum"), std::string::npos) << error_of(f);
}

TEST(ChunkFile, RejectsTruncatedAndOverlongFiles) {
  test::TempDir dir;
  const fs::path f = dir / "x.chunk";
  for (bool compress : {false, true}) {
    write_chunk_file(f, kId, test::random_block(40, 1), {compress, 1, true, false});
    const auto size = fs::file_size(f);
    fs::resize_file(f, size - 1);
    EXPECT_NE(error_of(f).find("truncated"), std::string::npos) << error_of(f);
    fs::resize_file(f, size + 1);
    EXPECT_NE(error_of(f).find("trailing"), std::string::npos) << error_of(f);
    fs::resize_file(f, 10);
    EXPECT_NE(error_of(f).find("shorter than a header"), std::string::npos) << error_of(f);
  }
  EXPECT_NE(error_of(dir / "missing").find("cannot open"), std::string::npos);
}

TEST(ChunkFile, RefusesToWriteInconsistentBlock) {
  test::TempDir dir;
  GaussianBlock b = test::random_block(10, 2);
  b.adam_v.opacity.pop_back();
  EXPECT_THROW(write_chunk_file(dir / "x", kId, b, {}), Error);
  EXPECT_FALSE(fs::exists(dir / "x"));
}

TEST(ChunkFile, FailedReadLeavesOutputUntouched) {
  test::TempDir dir;
  const fs::path f = dir / "x.chunk";
  write_chunk_file(f, kId, test::random_block(50, 1), {false, 1, false, false});
  flip_byte(f, 500);
  GaussianBlock keep = test::random_block(3, 4), copy = keep;
  EXPECT_THROW(read_chunk_file(f, keep), Error);
  EXPECT_TRUE(test::same_bits(keep, copy));
}

// A reader sizes its room from the manifest; a file of another chunk copied over this one said "room for
// 175 Gaussians given for 186". It now names the chunk the file holds.
TEST(ChunkFile, AReadIntoRoomOfAnotherCountNamesTheChunkTheFileHolds) {
  test::TempDir dir;
  const fs::path f = dir / "x.chunk";
  write_chunk_file(f, kId, test::random_block(12, 5), {true, 1, true, false});
  GaussianBlock room;
  std::string said;
  try {
    read_chunk_file(open_for_reading(f), f, [&](uint64_t, int sh) {
      room.sh_degree = sh;
      room.resize(9);
      return block_arrays(room);
    });
  } catch (const Error& e) {
    said = e.what();
  }
  for (const std::string& part : {std::string("x.chunk"), "holds 12 Gaussians of " + chunk_name(kId), std::string("where 9 were expected")})
    EXPECT_NE(said.find(part), std::string::npos) << said;
}

TEST(ChunkFile, RewriteLeavesNoTemporaries) {
  test::TempDir dir;
  const fs::path f = dir / "x.chunk";
  for (int i = 0; i < 5; ++i) write_chunk_file(f, kId, test::random_block(20, i), {false, 1, false, true});
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) files += e.is_regular_file(), (void)e;
  EXPECT_EQ(files, 1u);
}

// Content made while it is written (uncompressed chunk files): the head lands at the start once the
// content is in, and a failure while making it leaves the previous file as it was and no temporary.
TEST(AtomicFile, StreamedContentGetsItsHeadLastAndAFailureKeepsTheOldFile) {
  test::TempDir dir;
  const fs::path f = dir / "s.bin";
  const auto read_all = [&] {
    std::ifstream in(f, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  std::string head = "????";
  write_file_atomically(
      f, {head.data(), head.size()},
      [&](const Append& append) {
        append("abc", 3);
        append("", 0);
        append("defg", 4);
        head = "HEAD";  // known only now
      },
      false);
  EXPECT_EQ(read_all(), "HEADabcdefg");
  EXPECT_THROW(write_file_atomically(
                   f, {head.data(), head.size()},
                   [&](const Append& append) {
                     append("xyz", 3);
                     fail("made up");
                   },
                   true),
               Error);
  EXPECT_EQ(read_all(), "HEADabcdefg");
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) files += e.is_regular_file(), (void)e;
  EXPECT_EQ(files, 1u);
}
