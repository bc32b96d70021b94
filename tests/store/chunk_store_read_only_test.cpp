// Readers open a map read-only: the folder is read as its manifest commits it and never repaired,
// rewritten or pruned; every write throws; a listed chunk whose file is gone is an error naming it.
// (A reader's open used to drop such a chunk from the manifest, and delete its file when it came
// back.)
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "chungs/common/error.hpp"
#include "chungs/store/chunk_store.hpp"
#include "store/random_block.hpp"
#include "store/store_test_configs.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

ChunkStoreConfig writer() { return test::unflushed_store(); }

ChunkStoreConfig reader() {
  ChunkStoreConfig c;
  c.read_only = true;
  return c;
}

// Every file under the folder with its size and contents, for "nothing changed".
std::string snapshot(const fs::path& dir) {
  std::string out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::ifstream f(e.path(), std::ios::binary);
    std::stringstream s;
    s << f.rdbuf();
    out += e.path().string() + "\n" + s.str() + "\n";
  }
  return out;
}

const ChunkId kA = chunk_id({1, 2, 3}), kB = chunk_id({-4, 0, 7});

void make_map(const fs::path& dir) {
  ChunkStore s(dir, writer());
  s.save(kA, test::random_block(40, 1));
  s.save(kB, test::random_block(25, 2));
  s.commit();
}

TEST(ChunkStoreReadOnly, ReadsTheCommittedMapAndChangesNothing) {
  test::TempDir dir;
  make_map(dir.path());
  const std::string before = snapshot(dir.path());
  {
    ChunkStore s(dir.path(), reader());
    EXPECT_EQ(s.load(kA).size(), 40u);
    EXPECT_EQ(s.load(kB).size(), 25u);
    EXPECT_THROW(s.save(kA, test::random_block(3, 3)), Error);
    EXPECT_THROW(s.remove(kB), Error);
    EXPECT_THROW(s.set_config("x", "1"), Error);
    EXPECT_THROW(s.begin_snapshot(), Error);
  }
  EXPECT_EQ(snapshot(dir.path()), before);
}

TEST(ChunkStoreReadOnly, AMissingListedChunkIsNamedAndNothingIsDropped) {
  test::TempDir dir;
  make_map(dir.path());
  fs::path file;
  {
    ChunkStore s(dir.path(), reader());
    file = s.chunk_path(kB);
  }
  const fs::path aside = dir.path().parent_path() / (dir.path().filename().string() + "_aside.chunk");
  fs::rename(file, aside);
  const std::string before = snapshot(dir.path());
  try {
    ChunkStore s(dir.path(), reader());
    ADD_FAILURE() << "opened a map with a listed chunk missing";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(file.filename().string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(snapshot(dir.path()), before);
  // The file comes back: the map is whole again, and still readable by a writer.
  fs::rename(aside, file);
  ChunkStore s(dir.path(), reader());
  EXPECT_EQ(s.load(kB).size(), 25u);
}

TEST(ChunkStoreReadOnly, NewerUncommittedFilesAreNeitherAdoptedNorDeleted) {
  test::TempDir dir;
  make_map(dir.path());
  {
    ChunkStoreConfig c = writer();
    c.adopt_uncommitted = false;  // the mapper's way: its own checkpoints commit
    ChunkStore s(dir.path(), c);
    s.save(kA, test::random_block(7, 9));  // written, never committed
  }
  const std::string before = snapshot(dir.path());
  {
    ChunkStore s(dir.path(), reader());
    EXPECT_EQ(s.load(kA).size(), 40u);  // the committed generation
  }
  EXPECT_EQ(snapshot(dir.path()), before);
}

TEST(ChunkStoreReadOnly, AFolderWithoutAMapIsRefusedAndNotCreated) {
  test::TempDir dir;
  const fs::path none = dir / "nothing_here";
  EXPECT_THROW(ChunkStore(none, reader()), Error);
  EXPECT_FALSE(fs::exists(none));
}

TEST(ChunkStoreReadOnly, AChunkWhoseHeaderDisagreesWithTheManifestIsRefusedNamingBoth) {
  // Readers took the header's word: export wrote the file's 40 Gaussians where the manifest listed 7.
  test::TempDir dir;
  make_map(dir.path());
  const fs::path manifest_file = dir / "manifest.txt";
  const Manifest good = Manifest::read(manifest_file);
  const fs::path file = ChunkStore(dir.path(), reader()).chunk_path(kA);
  auto refused = [&](const Manifest& m, const std::string& says) {
    m.write(manifest_file, false);
    ChunkStore s(dir.path(), reader());
    try {
      s.load(kA);
      ADD_FAILURE() << "loaded a chunk that disagrees with the manifest: " << says;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  Manifest m = good;
  m.chunks[kA].count = 7;
  refused(m, "40 Gaussians, the manifest lists 7");
  m = good;
  m.chunks[kA].file_bytes = 12;
  refused(m, cat(good.chunks.at(kA).file_bytes, " bytes, the manifest lists 12"));
  // A file of SH degree 1 in a map of degree 3, the manifest otherwise matching it.
  GaussianBlock b = test::random_block(40, 1);
  b.sh_degree = 1;
  const ChunkFileInfo info = write_chunk_file(file, kA, b, {});
  m = good;
  m.chunks[kA] = {info.count, info.file_bytes, info.payload_checksum, good.chunks.at(kA).generation};
  refused(m, "SH degree 1, the map's is 3");
}

}  // namespace
