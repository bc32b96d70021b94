// Readers beside a writer (issue 21): a reader opens a map folder while a writer holds it and sees
// one committed manifest whole, whatever the writer commits meanwhile; a second writer is refused.
#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/store/chunk_store.hpp"
#include "store/random_block.hpp"
#include "store/store_test_configs.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

ChunkStoreConfig writer() { return test::exact_unflushed_store(); }
ChunkStoreConfig reader() { return reader_config(writer()); }

ChunkId cid(int x) { return chunk_id({x, -1, 3}); }

// Commit `round`'s content of chunk x: its count and bits tell the round apart.
GaussianBlock content(int round, int x) { return test::random_block(8 + (round * 7 + x) % 13, 1000 * round + x); }

void save_round(ChunkStore& w, int round, int chunks) {
  for (int x = 0; x < chunks; ++x) w.save(cid(x), content(round, x));
  w.set_config("checkpoint", std::to_string(round));
  w.commit();
}

int round_of(const ChunkStore& r) { return std::stoi(*r.config_value("checkpoint")); }

TEST(ChunkStoreReaders, AReaderOpensBesideAWriterAndAFileGoesOnlyAtTheCommitAfterItsSuccessor) {
  test::TempDir dir;
  ChunkStore w(dir.path(), writer());
  save_round(w, 1, 4);
  ChunkStore r(dir.path(), reader());  // the writer's lock no longer keeps it out
  ASSERT_EQ(round_of(r), 1);
  // A reader that has read manifest 1 and not yet opened its files: they survive commit 2 ...
  const Manifest first = Manifest::read(w.manifest_path());
  save_round(w, 2, 4);
  for (const auto& [id, e] : first.chunks) EXPECT_TRUE(fs::exists(w.chunk_file(id, e.generation)));
  // ... and go at commit 3, when a reader still opening them starts over from manifest 3.
  save_round(w, 3, 4);
  for (const auto& [id, e] : first.chunks) EXPECT_FALSE(fs::exists(w.chunk_file(id, e.generation)));
  // The reader that opened at commit 1 holds its files: it still loads round 1, every chunk whole.
  for (int x = 0; x < 4; ++x) EXPECT_TRUE(test::same_bits(r.load(cid(x)), content(1, x))) << x;
  ChunkStore later(dir.path(), reader());
  EXPECT_EQ(round_of(later), 3);
  for (int x = 0; x < 4; ++x) EXPECT_TRUE(test::same_bits(later.load(cid(x)), content(3, x))) << x;
  EXPECT_THROW(ChunkStore(dir.path(), writer()), Error) << "a second writer is refused";
}

TEST(ChunkStoreReaders, AFileGoneWithoutANewCommitIsDamageNamedAtOnce) {
  test::TempDir dir;
  {
    ChunkStore w(dir.path(), writer());
    save_round(w, 1, 3);
  }
  const Manifest m = Manifest::read(dir / "manifest.txt");
  const auto& [id, e] = *m.chunks.begin();
  ChunkStore probe(dir.path(), reader());
  const fs::path gone = probe.chunk_file(id, e.generation);
  fs::remove(gone);
  try {
    ChunkStore r(dir.path(), reader());
    FAIL() << "opened a map missing " << gone;
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find(gone.filename().string()), std::string::npos) << err.what();
    EXPECT_NE(std::string(err.what()).find("missing"), std::string::npos) << err.what();
  }
  // The reader opened before the damage holds the file still.
  EXPECT_TRUE(test::same_bits(probe.load(id), content(1, int(id == cid(0) ? 0 : id == cid(1) ? 1 : 2))));
}

TEST(ChunkStoreReaders, ReadersNeverSeeAMixOfCommitsWhileAWriterCommitsInALoop) {
  test::TempDir dir;
  constexpr int kChunks = 60;
  ChunkStore w(dir.path(), writer());
  save_round(w, 1, kChunks);
  std::atomic<bool> done{false};
  std::atomic<int> rounds{1};
  std::thread t([&] {
    for (int round = 2; round <= 30; ++round) {
      save_round(w, round, kChunks);
      rounds = round;
    }
    done = true;
  });
  int opened = 0, gave_up = 0, mixed = 0;
  size_t rereads = 0;
  std::string other;
  while (!done || opened == 0) {
    try {
      ChunkStore r(dir.path(), reader());
      rereads += r.open_report().rereads;
      const int round = round_of(r);
      for (int x = 0; x < kChunks; ++x)
        if (!test::same_bits(r.load(cid(x)), content(round, x))) ++mixed;
      ++opened;
    } catch (const Error& e) {
      const std::string what = e.what();
      if (what.find("the map changed faster than it could be read; try again") != std::string::npos)
        ++gave_up;
      else
        other = what;
    }
  }
  t.join();
  EXPECT_EQ(mixed, 0);
  EXPECT_EQ(other, "");
  EXPECT_GT(opened, 0);
  std::printf("%d reads beside %d commits: %d gave up, %zu manifests read again\n", opened + gave_up,
              rounds.load(), gave_up, rereads);
}

}  // namespace
