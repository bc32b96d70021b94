#include "chungs/store/chunk_store.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

#include "chungs/common/error.hpp"
#include "store/random_block.hpp"
#include "store/store_test_configs.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

TEST(ChunkStore, SavedChunksSurviveCloseAndReopen) {
  test::TempDir dir;
  std::map<ChunkId, GaussianBlock> ref;
  {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    for (int i = 0; i < 20; ++i) {
      const ChunkId id = chunk_id({i, -i, i % 4});
      ref[id] = test::random_block(10 + i, i);
      s.save(id, ref[id]);
    }
    s.set_config("dataset", "synthetic city");
  }
  ChunkStore s(dir.path(), test::exact_unflushed_store());
  EXPECT_FALSE(s.open_report().repaired());
  EXPECT_EQ(s.size(), ref.size());
  EXPECT_EQ(s.config_value("dataset"), "synthetic city");
  uint64_t total = 0;
  for (const auto& [id, b] : ref) {
    EXPECT_EQ(s.count(id), b.size());
    EXPECT_TRUE(test::same_bits(s.load(id), b));
    total += b.size();
  }
  EXPECT_EQ(s.total_gaussians(), total);
  const auto st = s.counters().snapshot();
  EXPECT_EQ(st.loads, ref.size());
  EXPECT_GT(st.bytes_read, total * kChunkBytesPerGaussian);
}

TEST(ChunkStore, CompressedMapReopensWithCompressionOff) {
  test::TempDir dir;
  const ChunkId id = chunk_id({1, 2, 3});
  const GaussianBlock b = test::random_block(500, 3);
  {
    ChunkStoreConfig c = test::exact_unflushed_store();
    c.compress = true;
    ChunkStore s(dir.path(), c);
    s.save(id, b);
  }
  ChunkStore s(dir.path(), test::exact_unflushed_store());
  EXPECT_TRUE(test::same_bits(s.load(id), b));
}

TEST(ChunkStore, EmptyBlockRemovesTheChunk) {
  test::TempDir dir;
  ChunkStore s(dir.path(), test::exact_unflushed_store());
  const ChunkId id = chunk_id({0, 0, 0});
  s.save(id, test::random_block(3, 1));
  EXPECT_TRUE(fs::exists(s.chunk_path(id)));
  s.save(id, GaussianBlock{});
  EXPECT_FALSE(s.contains(id));
  EXPECT_FALSE(fs::exists(s.chunk_path(id)));
  EXPECT_THROW(s.load(id), Error);
  s.remove(id);  // absent: no-op
}

TEST(ChunkStore, RefusesASecondOpenOfTheSameFolder) {
  test::TempDir dir;
  ChunkStore s(dir.path(), test::exact_unflushed_store());
  try {
    ChunkStore t(dir.path(), test::exact_unflushed_store());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("already open"), std::string::npos) << e.what();
  }
}

TEST(ChunkStore, ReopenAdoptsUpdatesAndDropsWhatHappenedAfterTheLastCommit) {
  test::TempDir dir;
  const ChunkId a = chunk_id({1, 0, 0}), b = chunk_id({2, 0, 0}), c = chunk_id({3, 0, 0});
  const GaussianBlock ba = test::random_block(5, 1), bb = test::random_block(6, 2), bc = test::random_block(7, 3);
  {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    s.save(a, ba);
    s.save(b, bb);
  }
  const fs::path manifest_before = dir / "manifest.txt";
  const std::string saved = [&] {
    std::ifstream f(manifest_before);
    return std::string(std::istreambuf_iterator<char>(f), {});
  }();
  GaussianBlock bb2 = test::random_block(9, 4);
  test::TempDir crashed;
  {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    s.save(b, bb2);   // updated
    s.save(c, bc);    // adopted
    s.remove(a);      // dropped
    // The folder as a process that died before committing leaves it (a clean close commits).
    fs::copy(dir.path(), crashed.path(), fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  }
  fs::remove(crashed / "lock");
  {
    std::ifstream f(crashed / "manifest.txt");
    ASSERT_EQ(std::string(std::istreambuf_iterator<char>(f), {}), saved);  // the session's changes uncommitted
  }
  std::ofstream(crashed / "chunks" / "0000000000000001.chunk.tmp-1-2") << "half a write";
  ChunkStore s(crashed.path(), test::exact_unflushed_store());
  const auto& r = s.open_report();
  EXPECT_EQ(r.entries_adopted, 1u);
  EXPECT_EQ(r.entries_updated, 1u);
  EXPECT_EQ(r.entries_dropped, 1u);
  EXPECT_EQ(r.temporaries_removed, 1u);
  EXPECT_FALSE(s.contains(a));
  EXPECT_TRUE(test::same_bits(s.load(b), bb2));
  EXPECT_TRUE(test::same_bits(s.load(c), bc));
  // The repair was committed at once: the manifest on disk now matches.
  const Manifest m = Manifest::read(crashed / "manifest.txt");
  EXPECT_EQ(m.chunks, s.manifest().chunks);
}

TEST(ChunkStore, RebuildsAMissingManifestFromTheChunkFiles) {
  test::TempDir dir;
  const ChunkId id = chunk_id({-4, 5, 6});
  const GaussianBlock b = test::random_block(11, 8);
  {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    s.save(id, b);
  }
  fs::remove(dir / "manifest.txt");
  ChunkStore s(dir.path(), test::exact_unflushed_store());
  EXPECT_EQ(s.count(id), 11u);
  EXPECT_TRUE(test::same_bits(s.load(id), b));
}

TEST(ChunkStore, RejectsAChunkFileThatNamesAnotherChunk) {
  test::TempDir dir;
  const ChunkId a = chunk_id({1, 1, 1}), b = chunk_id({2, 2, 2});
  fs::path pa, pb;
  {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    s.save(a, test::random_block(4, 1));
    pa = s.chunk_path(a), pb = s.chunk_path(b);
  }
  fs::rename(pa, pb);
  try {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(pb.string()), std::string::npos) << e.what();
  }
}

TEST(ChunkStore, RejectsACorruptManifestWithAHint) {
  test::TempDir dir;
  { ChunkStore s(dir.path(), test::exact_unflushed_store()); s.set_config("k", "v"); }
  std::ofstream(dir / "manifest.txt", std::ios::app) << "junk\n";
  try {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("delete it, and `run --resume` rebuilds it"), std::string::npos) << e.what();
  }
}

TEST(ChunkStore, ExistingMapKeepsItsChunkSize) {
  test::TempDir dir;
  ChunkStoreConfig c = test::exact_unflushed_store();
  c.chunk_size = 4.0;
  { ChunkStore s(dir.path(), c); }
  ChunkStore s(dir.path(), test::exact_unflushed_store());
  EXPECT_EQ(s.chunk_size(), 4.0);
}

TEST(ChunkStore, VerifyOnOpenCatchesPayloadCorruption) {
  test::TempDir dir;
  const ChunkId id = chunk_id({0, 1, 0});
  fs::path p;
  {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    s.save(id, test::random_block(30, 1));
    p = s.chunk_path(id);
  }
  {
    std::fstream f(p, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(1000);
    f.put('\x7f');
  }
  EXPECT_NO_THROW(ChunkStore(dir.path(), test::exact_unflushed_store()));  // header-only check by default
  ChunkStoreConfig c = test::exact_unflushed_store();
  c.verify_on_open = true;
  EXPECT_THROW(ChunkStore(dir.path(), c), Error);
}

TEST(ChunkStore, AListedChunkWhoseFileIsGoneIsRefusedNamingTheFileAndTheFolderIsLeftAsItIs) {
  // It was dropped from the map with a warning, and the repair then deleted the chunk's older file,
  // which a rebuild from the chunk files could still have used; the readers refused the same map.
  test::TempDir dir;
  const ChunkId a = chunk_id({1, 0, 0}), b = chunk_id({2, 0, 0});
  const GaussianBlock older = test::random_block(6, 2);
  fs::path gone;
  {
    ChunkStore s(dir.path(), test::exact_unflushed_store());
    s.save(a, test::random_block(5, 1));
    s.save(b, older);
    s.commit();
    s.save(b, test::random_block(7, 3));
    s.commit();
    gone = s.chunk_path(b);
    // As a crash now leaves it: the manifest names b's newer file; its older one waits a commit to go.
    fs::copy(dir.path(), dir.path().string() + "-crashed", fs::copy_options::recursive);
  }
  const fs::path crashed = dir.path().string() + "-crashed";
  fs::remove(crashed / "lock");
  fs::remove(crashed / "chunks" / gone.filename());
  auto listing = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::recursive_directory_iterator(crashed)) names.push_back(e.path().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  std::stringstream manifest_before;
  manifest_before << std::ifstream(crashed / "manifest.txt").rdbuf();
  const auto files_before = listing();
  for (bool adopt : {false, true}) {
    ChunkStoreConfig c = test::exact_unflushed_store();
    c.adopt_uncommitted = adopt;
    try {
      ChunkStore s(crashed, c);
      ADD_FAILURE() << "a map whose listed chunk file is gone was opened";
    } catch (const Error& e) {
      const std::string said = e.what();
      EXPECT_NE(said.find(gone.filename().string()), std::string::npos) << said;
      EXPECT_NE(said.find("left as it is"), std::string::npos) << said;
    }
    fs::remove(crashed / "lock");
    std::stringstream manifest_after;
    manifest_after << std::ifstream(crashed / "manifest.txt").rdbuf();
    EXPECT_EQ(manifest_after.str(), manifest_before.str());
    EXPECT_EQ(listing(), files_before);
  }
  // The way out the message gives: without the manifest, the map is rebuilt from what is there, b
  // from its older file.
  fs::remove(crashed / "manifest.txt");
  ChunkStoreConfig rebuild = test::exact_unflushed_store();
  rebuild.adopt_uncommitted = true;
  ChunkStore s(crashed, rebuild);
  ASSERT_TRUE(s.contains(b));
  EXPECT_TRUE(test::same_bits(s.load(b), older));
  fs::remove_all(crashed);
}
