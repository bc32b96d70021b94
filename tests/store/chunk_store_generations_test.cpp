// Generations of chunk files: a save never overwrites the file the manifest on disk names; the
// superseded file goes once a commit no longer needs it; one flush per changed chunk per commit.
#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/store/checksum.hpp"
#include "chungs/store/chunk_file_name.hpp"
#include "chungs/store/chunk_store.hpp"
#include "chungs/store/disk_usage.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
std::vector<std::string> chunk_folder(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir / "chunks")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}
ChunkStoreConfig kill_safe() {
  ChunkStoreConfig c;
  c.half_moments = c.half_sh_rest = false;  // these tests compare exact round trips
  c.durable = false;
  return c;
}
}  // namespace

TEST(ChunkFileName, RoundTripsAndRejectsForeignNames) {
  const ChunkId id = chunk_id({3, -4, 5});
  for (uint64_t g : {uint64_t(0), uint64_t(1), uint64_t(0xabcdef123)})
    for (bool t : {false, true}) {
      if (g == 0 && t) continue;
      const auto n = parse_chunk_file_name(chunk_file_name(id, g, t));
      ASSERT_TRUE(n);
      EXPECT_EQ(n->id, id);
      EXPECT_EQ(n->generation, g);
      EXPECT_EQ(n->tombstone, t);
    }
  for (const char* bad :
       {"0123456789abcdef.chunk.tmp-1-2", "0123456789abcdeg.chunk", "0123456789abcdef-.chunk",
        "0123456789abcdef-0000000000000000.chunk", "0123456789abcdef.removed", "manifest.txt"})
    EXPECT_FALSE(parse_chunk_file_name(bad)) << bad;
}

TEST(ChunkStore, SaveKeepsTheCommittedFileUntilTheCommitAfterTheNext) {
  test::TempDir dir;
  ChunkStore s(dir.path(), kill_safe());
  const ChunkId id = chunk_id({1, 2, 3});
  s.save(id, test::random_block(5, 1));
  s.commit();
  const fs::path committed = s.chunk_path(id);
  const GaussianBlock v2 = test::random_block(6, 2);
  s.save(id, v2);
  s.save(id, test::random_block(7, 3));  // the uncommitted generation in between goes at once
  s.save(id, v2);
  EXPECT_EQ(chunk_folder(dir.path()).size(), 2u);
  EXPECT_TRUE(fs::exists(committed));
  EXPECT_NE(s.chunk_path(id), committed);
  s.commit();
  EXPECT_TRUE(fs::exists(committed)) << "a reader of the previous manifest may still be opening it";
  s.commit();
  EXPECT_TRUE(fs::exists(committed)) << "a commit that writes no manifest does not advance";
  s.set_config("k", "v");
  s.commit();
  EXPECT_FALSE(fs::exists(committed));
  EXPECT_EQ(chunk_folder(dir.path()), std::vector<std::string>{s.chunk_path(id).filename().string()});
  EXPECT_TRUE(test::same_bits(s.load(id), v2));
}

TEST(ChunkStore, RemovalLeavesATombstoneThatAReopenHonours) {
  test::TempDir dir, crashed;
  const ChunkId a = chunk_id({0, 0, 1}), b = chunk_id({0, 0, 2});
  {
    ChunkStore s(dir.path(), kill_safe());
    s.save(a, test::random_block(5, 1));
    s.save(b, test::random_block(5, 2));
    s.commit();
    s.remove(a);
    EXPECT_EQ(chunk_folder(dir.path()).size(), 3u);  // a's committed file, its tombstone, b
    // A crash here (no commit): copy the folder as it is.
    fs::copy(dir.path(), crashed.path(), fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    s.commit();
    EXPECT_EQ(chunk_folder(dir.path()).size(), 2u);  // the tombstone went, a's file waits a commit
  }
  EXPECT_EQ(chunk_folder(dir.path()).size(), 1u);  // a clean close leaves only what is named
  const fs::path copy = crashed.path();
  fs::remove(copy / "lock");
  {
    ChunkStore s(copy, kill_safe());
    EXPECT_FALSE(s.contains(a));
    EXPECT_TRUE(s.contains(b));
    EXPECT_EQ(s.open_report().entries_dropped, 1u);
    EXPECT_EQ(s.open_report().orphans, 2u);
  }
  EXPECT_EQ(chunk_folder(copy).size(), 1u);  // the repair committed and cleaned up
}

TEST(ChunkStore, AdoptsAGenerationNewerThanTheManifestOnlyIfItReadsBackWhole) {
  const ChunkId id = chunk_id({5, 5, 5});
  const GaussianBlock v1 = test::random_block(20, 1), v2 = test::random_block(21, 2);
  for (bool torn : {false, true}) {
    test::TempDir dir, crashed;
    fs::path newer;
    {
      ChunkStore s(dir.path(), kill_safe());
      s.save(id, v1);
      s.commit();
      s.save(id, v2);
      newer = crashed / "chunks" / s.chunk_path(id).filename();
      // The folder as a process killed now would leave it.
      fs::copy(dir.path(), crashed.path(),
               fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    }
    fs::remove(crashed / "lock");
    if (torn) fs::resize_file(newer, fs::file_size(newer) - 100);
    {
      ChunkStore s(crashed.path(), kill_safe());
      EXPECT_TRUE(test::same_bits(s.load(id), torn ? v1 : v2)) << "torn " << torn;
      EXPECT_EQ(s.open_report().files_rejected, torn ? 1u : 0u);
      // The manifest found on disk names v1: a reader of it may be opening that file.
      EXPECT_EQ(chunk_folder(crashed.path()).size(), torn ? 1u : 2u);
    }
    EXPECT_EQ(chunk_folder(crashed.path()).size(), 1u);
  }
}

TEST(ChunkStore, ReadsTheVersion1LayoutAndSupersedesIt) {
  test::TempDir dir;
  const ChunkId id = chunk_id({-2, 0, 7});
  const GaussianBlock v1 = test::random_block(9, 4);
  fs::create_directories(dir / "chunks");
  const fs::path legacy = dir / "chunks" / chunk_file_name(id, 0, false);
  const ChunkFileInfo info = write_chunk_file(legacy, id, v1, {false, 1, false, false});
  // A version 1 manifest as the previous build wrote it: 4 fields per chunk, no generations.
  char text[256];
  std::snprintf(text, sizeof text,
                "diskchungs-manifest 1\nchunk_size 10\nsh_degree 3\nchunk %016llx %llu %llu %016llx\n",
                (unsigned long long)id, (unsigned long long)info.count, (unsigned long long)info.file_bytes,
                (unsigned long long)info.payload_checksum);
  const std::string body = text;
  char end[64];
  std::snprintf(end, sizeof end, "end 1 %016llx\n", (unsigned long long)xxh64(body.data(), body.size()));
  std::ofstream(dir / "manifest.txt") << body << end;
  const Manifest v1_manifest = Manifest::read(dir / "manifest.txt");
  EXPECT_EQ(v1_manifest.chunks.at(id).generation, 0u);
  EXPECT_EQ(v1_manifest.next_generation, 0u);
  ChunkStore s(dir.path(), kill_safe());
  EXPECT_FALSE(s.open_report().repaired());
  EXPECT_TRUE(test::same_bits(s.load(id), v1));
  s.save(id, test::random_block(10, 5));
  s.commit();
  s.set_config("k", "v");
  s.commit();
  EXPECT_FALSE(fs::exists(legacy));
  EXPECT_EQ(Manifest::read(dir / "manifest.txt").chunks.at(id).generation, 1u);
}

TEST(ChunkStore, CommitFlushesEachChangedChunkOnceNotEachSave) {
  test::TempDir dir;
  ChunkStore s(dir.path());  // durable
  s.counters().reset();
  for (int round = 0; round < 3; ++round)
    for (int k = 0; k < 4; ++k) s.save(chunk_id({k, 0, 0}), test::random_block(4, uint64_t(10 * round + k)));
  s.commit();
  IoStats st = s.counters().snapshot();
  EXPECT_EQ(st.saves, 12u);
  EXPECT_EQ(st.barriers, 1u);
  EXPECT_EQ(st.synced_files, 4u);
  EXPECT_GT(st.barrier_ms, 0.0);
  s.commit();  // nothing changed: no barrier
  EXPECT_EQ(s.counters().snapshot().barriers, 1u);
  const DiskUsage u = disk_usage(dir.path());
  EXPECT_EQ(u.files, 4u + 2u);  // four chunks, manifest, lock
  uint64_t expected = fs::file_size(dir / "manifest.txt");
  for (int k = 0; k < 4; ++k) expected += fs::file_size(s.chunk_path(chunk_id({k, 0, 0})));
  EXPECT_EQ(u.bytes, expected);
  EXPECT_GE(u.allocated_bytes, 4u * 4096u);
  EXPECT_THROW(disk_usage(dir / "missing"), Error);
}
