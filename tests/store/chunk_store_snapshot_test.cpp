// Snapshots: the committed manifest is the map of the snapshot's moment, whatever the live map
// did meanwhile; no file the snapshot names is lost, none only it named is left behind.
#include <gtest/gtest.h>

#include "chungs/common/error.hpp"
#include "chungs/store/chunk_store.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
ChunkId cid(int x) { return chunk_id({x, 2, -1}); }

ChunkStoreConfig rollback_config(bool durable) {
  ChunkStoreConfig c;
  c.half_moments = c.half_sh_rest = false;  // these tests compare exact round trips
  c.durable = durable;
  c.adopt_uncommitted = false;  // as the mapper opens it: back to the last commit
  return c;
}

// What a process killed now would find: a copy of the folder, opened as the mapper does.
void copy_folder(const fs::path& from, const fs::path& to) {
  fs::create_directories(to / "chunks");
  for (const auto& e : fs::directory_iterator(from / "chunks")) fs::copy_file(e.path(), to / "chunks" / e.path().filename());
  fs::copy_file(from / "manifest.txt", to / "manifest.txt");
}

size_t chunk_files(const fs::path& folder) {
  size_t n = 0;
  for (const auto& e : fs::directory_iterator(folder / "chunks")) n += e.is_regular_file();
  return n;
}
}  // namespace

TEST(ChunkStoreSnapshot, CommitsTheMapOfItsMomentWhileLiveSavesGoOn) {
  for (bool durable : {false, true}) {
    test::TempDir dir, killed;
    ChunkStore store(dir.path(), rollback_config(durable));
    for (int x = 0; x < 4; ++x) store.save(cid(x), test::random_block(20 + x, 10 + x));
    store.commit();
    store.save(cid(0), test::random_block(30, 100));  // before the snapshot, never committed
    store.save(cid(3), {});                            // removed before the snapshot
    store.set_config("checkpoint", "7");
    store.begin_snapshot();
    EXPECT_TRUE(store.snapshot_pending());
    // The live map moves on: chunk 0 again (its snapshot file is superseded), chunk 1, a new chunk 5,
    // chunk 2 removed; the snapshot gets chunk 1's and chunk 4's content of its moment.
    store.save(cid(0), test::random_block(31, 200));
    store.save(cid(1), test::random_block(32, 201));
    store.save(cid(5), test::random_block(33, 202));
    store.save(cid(2), {});
    store.save_to_snapshot(cid(1), test::random_block(25, 300));
    store.save_to_snapshot(cid(4), test::random_block(26, 301));
    store.set_config("checkpoint", "8");  // after the snapshot: not in it
    EXPECT_THROW(store.commit(), Error) << "the live map must not be committed over a pending snapshot";
    store.commit_snapshot();
    EXPECT_FALSE(store.snapshot_pending());

    // Loads see the live map.
    EXPECT_TRUE(test::same_bits(store.load(cid(0)), test::random_block(31, 200)));
    EXPECT_TRUE(test::same_bits(store.load(cid(1)), test::random_block(32, 201)));
    EXPECT_FALSE(store.contains(cid(2)));
    EXPECT_FALSE(store.contains(cid(4)));

    copy_folder(dir.path(), killed.path());
    {
      ChunkStore after(killed.path(), rollback_config(durable));
      EXPECT_EQ(after.config_value("checkpoint"), "7");
      EXPECT_EQ(after.ids(), (std::vector<ChunkId>{cid(0), cid(1), cid(2), cid(4)}));
      EXPECT_TRUE(test::same_bits(after.load(cid(0)), test::random_block(30, 100)));
      EXPECT_TRUE(test::same_bits(after.load(cid(1)), test::random_block(25, 300)));
      EXPECT_TRUE(test::same_bits(after.load(cid(2)), test::random_block(22, 12)));
      EXPECT_TRUE(test::same_bits(after.load(cid(4)), test::random_block(26, 301)));
      EXPECT_EQ(chunk_files(killed.path()), 4u) << "files the manifest does not name are orphans";
    }
    // A commit of the live map afterwards drops what only the snapshot named, at the commit after
    // it: a reader may have read the snapshot's manifest and be opening its files.
    const Manifest snapshot_map = Manifest::read(dir / "manifest.txt");
    store.commit();
    for (const auto& [id, e] : snapshot_map.chunks) EXPECT_TRUE(fs::exists(store.chunk_file(id, e.generation)));
    EXPECT_EQ(store.config_value("checkpoint"), "8");
    store.set_config("checkpoint", "9");
    store.commit();
    EXPECT_EQ(chunk_files(dir.path()), store.size()) << "durable " << durable;
  }
}

TEST(ChunkStoreSnapshot, AnAbandonedSnapshotLeavesTheLastCommitAndNoFiles) {
  test::TempDir dir, killed;
  ChunkStore store(dir.path(), rollback_config(false));
  store.save(cid(0), test::random_block(10, 1));
  store.save(cid(1), test::random_block(11, 2));
  store.commit();
  store.begin_snapshot();
  EXPECT_THROW(store.begin_snapshot(), Error);
  store.save_to_snapshot(cid(0), test::random_block(12, 3));
  store.save(cid(1), test::random_block(13, 4));
  store.abandon_snapshot();
  copy_folder(dir.path(), killed.path());
  {
    ChunkStore after(killed.path(), rollback_config(false));
    EXPECT_TRUE(test::same_bits(after.load(cid(0)), test::random_block(10, 1)));
    EXPECT_TRUE(test::same_bits(after.load(cid(1)), test::random_block(11, 2)));
  }
  store.commit();
  EXPECT_EQ(chunk_files(dir.path()), 3u) << "chunk 1's committed file stays for one more commit";
  store.set_config("checkpoint", "1");
  store.commit();
  EXPECT_EQ(chunk_files(dir.path()), 2u);
  EXPECT_THROW(store.save_to_snapshot(cid(0), test::random_block(1, 1)), Error) << "no snapshot pending";
  EXPECT_THROW(store.commit_snapshot(), Error);
}
