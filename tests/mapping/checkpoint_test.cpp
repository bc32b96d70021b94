// A map folder after a crash matches its last checkpoint: chunk files saved after it are rolled
// back (no Gaussians of keyframes the resumed run will add again), and a crash between the commit
// and the renaming of the keyframe list and run state finishes the renaming on open.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "chungs/common/log.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/store/chunk_store.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

namespace fs = std::filesystem;

Config small_config() {
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  return c;
}

void add_frames(Mapper& m, const test::WallSequence& seq, size_t from, size_t to) {
  for (size_t i = from; i < to; ++i) {
    const Frame f = seq.frame(i);
    m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    for (int k = 0; k < 3; ++k) m.step();
  }
}

// Every Gaussian of the map folder, by the keyframe that created it (read with the store alone).
std::vector<uint32_t> creators(const fs::path& folder) {
  ChunkStoreConfig sc;
  sc.half_moments = sc.half_sh_rest = false;  // these tests compare exact round trips
  sc.adopt_uncommitted = false;
  ChunkStore store(folder, sc);
  std::vector<uint32_t> out;
  for (ChunkId id : store.ids()) {
    const GaussianBlock b = store.load(id);
    out.insert(out.end(), b.created_by_keyframe.begin(), b.created_by_keyframe.end());
  }
  return out;
}

// What a kill at this moment leaves; background threads may be writing or deleting files meanwhile.
void copy_folder(const fs::path& from, const fs::path& to) {
  fs::create_directories(to);
  for (const auto& e : fs::recursive_directory_iterator(from)) {
    const fs::path target = to / fs::relative(e.path(), from);
    std::error_code ec;
    if (e.is_directory(ec))
      fs::create_directories(target);
    else if (e.path().filename() != "lock")
      fs::copy_file(e.path(), target, fs::copy_options::overwrite_existing, ec);
  }
}

TEST(MapperCheckpoint, CrashBeforeTheCommitRollsTheMapBackToTheLastCheckpoint) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(10);
  const Config c = small_config();
  const fs::path a = dir / "a", b = dir / "b";
  {
    Mapper m(b, c, false);
    add_frames(m, seq, 0, 4);
    m.checkpoint({{"next_frame", 4}});
    copy_folder(b, a);  // the folder as checkpoint 1 left it
    add_frames(m, seq, 4, 9);
    m.checkpoint({{"next_frame", 9}});
  }
  // Checkpoint 2 crashed after its chunk files and numbered state files, before the commit.
  for (const auto& e : fs::directory_iterator(b / "chunks"))
    if (!fs::exists(a / "chunks" / e.path().filename())) fs::copy_file(e.path(), a / "chunks" / e.path().filename());
  fs::copy_file(b / "keyframes.txt", a / "checkpoint-2-keyframes.txt");
  fs::copy_file(b / "run_state.json", a / "checkpoint-2-run_state.json");
  {
    Mapper m(a, c, true);
    EXPECT_EQ(m.keyframes().size(), 4u);
    EXPECT_EQ(m.resumed_state()["next_frame"].get<int>(), 4);
  }
  EXPECT_FALSE(fs::exists(a / "checkpoint-2-keyframes.txt"));
  EXPECT_FALSE(fs::exists(a / "checkpoint-2-run_state.json"));
  const auto ids = creators(a);
  ASSERT_FALSE(ids.empty());
  for (uint32_t k : ids) ASSERT_LT(k, 4u) << "a Gaussian of keyframe " << k << " survived the rollback";
  EXPECT_LT(ids.size(), creators(b).size());
}

TEST(MapperCheckpoint, CrashAfterTheCommitFinishesTheRenamingOnOpen) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(10);
  const Config c = small_config();
  const fs::path b = dir / "b";
  std::string old_keyframes;
  {
    Mapper m(b, c, false);
    add_frames(m, seq, 0, 3);
    m.checkpoint({{"next_frame", 3}});
    fs::copy_file(b / "keyframes.txt", dir / "kf1.txt");
    add_frames(m, seq, 3, 7);
    m.checkpoint({{"next_frame", 7}});
  }
  // Committed, but the new keyframe list still has its numbered name and the old one is in place.
  fs::rename(b / "keyframes.txt", b / "checkpoint-2-keyframes.txt");
  fs::copy_file(dir / "kf1.txt", b / "keyframes.txt");
  {
    Mapper m(b, c, true);
    EXPECT_EQ(m.keyframes().size(), 7u);
  }
  EXPECT_FALSE(fs::exists(b / "checkpoint-2-keyframes.txt"));
  EXPECT_EQ(read_keyframe_records(b / "keyframes.txt").size(), 7u);
  for (uint32_t k : creators(b)) ASSERT_LT(k, 7u);
}

TEST(MapperCheckpoint, ClosingWithoutACheckpointLeavesTheLastOne) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(10);
  Config c = small_config();
  c.residency.budget_gaussians = 3000;  // evictions write chunks between the checkpoints
  const fs::path b = dir / "b";
  {
    Mapper m(b, c, false);
    add_frames(m, seq, 0, 4);
    m.checkpoint({{"next_frame", 4}});
    add_frames(m, seq, 4, 9);  // then an error ends the run: no checkpoint
  }
  {
    Mapper m(b, c, true);
    EXPECT_EQ(m.keyframes().size(), 4u);
  }
  const auto ids = creators(b);
  ASSERT_FALSE(ids.empty());
  for (uint32_t k : ids) ASSERT_LT(k, 4u) << "a Gaussian of keyframe " << k << " outlived its run's last checkpoint";
}

// The levels of a map's chunks were chosen by the distance it was made with: a resumed run keeps it,
// whatever its settings say, and goes on adding to both levels the same way.
TEST(MapperCheckpoint, AResumedMapKeepsTheFarLevelDistanceItWasMadeWith) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(10);
  Config c = small_config();
  c.culling.far_level_distance = 3.2;  // the wall 3 m ahead: the cubes in front near, those aside far
  const fs::path m_dir = dir / "m";
  {
    Mapper m(m_dir, c, false);
    add_frames(m, seq, 0, 4);
    m.checkpoint({{"next_frame", 4}});
  }
  Config other = c;
  other.culling.far_level_distance = 70;
  {
    Mapper m(m_dir, other, true);
    EXPECT_DOUBLE_EQ(m.config().culling.far_level_distance, 3.2);
    add_frames(m, seq, 4, 8);
    m.checkpoint({{"next_frame", 8}});
  }
  const ChunkStore store(m_dir, reader_config());
  EXPECT_EQ(store.config_value("far_level_distance"), std::optional<std::string>("3.2"));
  size_t far = 0, near = 0;
  for (ChunkId id : store.ids()) (is_far_level(id) ? far : near)++;
  EXPECT_GT(far, 0u);
  EXPECT_GT(near, 0u);
}

// A manifest lost (deleted after it read back corrupt, as the readers' error advises) leaves the chunk files:
// --resume rebuilds the map from them, its far level included, instead of rolling every chunk back to an
// empty map, and goes on mapping.
TEST(MapperCheckpoint, AMapWhoseManifestIsLostIsRebuiltFromItsChunkFilesOnResume) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  const test::WallSequence seq(10);
  Config c = small_config();
  c.culling.far_level_distance = 3.2;  // both levels (see above)
  const fs::path m_dir = dir / "m";
  {
    Mapper m(m_dir, c, false);
    add_frames(m, seq, 0, 4);
    m.checkpoint({{"next_frame", 4}});
  }
  std::vector<std::pair<ChunkId, uint64_t>> before;
  {
    const ChunkStore store(m_dir, reader_config());
    before = store.counts();
  }
  ASSERT_GT(before.size(), 2u);
  ASSERT_TRUE(is_far_level(before.back().first));
  fs::remove(m_dir / "manifest.txt");
  // The chunk size and SH degree went with the manifest too: the run state committed with it names them,
  // so settings that differ (a user resuming without the map's --chunk-size) do not misplace the chunks.
  Config other = c;
  other.store.chunk_size = 2 * c.store.chunk_size;
  other.store.sh_degree = 1;
  {
    Mapper m(m_dir, other, true);
    EXPECT_EQ(m.keyframes().size(), 4u);
    EXPECT_DOUBLE_EQ(m.config().culling.far_level_distance, 3.2);
    {
      const ChunkStore store(m_dir, reader_config());  // as a reader beside the resumed run sees it
      EXPECT_EQ(store.counts(), before);
      EXPECT_EQ(store.config_value("far_level_distance"), std::optional<std::string>("3.2"));
      EXPECT_EQ(store.chunk_size(), c.store.chunk_size);
      EXPECT_EQ(store.sh_degree(), c.store.sh_degree);
    }
    add_frames(m, seq, 4, 8);
    m.checkpoint({{"next_frame", 8}});
  }
  const ChunkStore store(m_dir, reader_config());
  size_t far = 0, near = 0;
  for (ChunkId id : store.ids()) (is_far_level(id) ? far : near)++;
  EXPECT_GT(far, 0u);
  EXPECT_GT(near, 0u);
  EXPECT_GE(store.size(), before.size());
}

// Every file but the lock, by name: a hash of its contents.
std::map<std::string, size_t> contents(const fs::path& folder);

// With the chunk files gone too there is nothing to rebuild from: --resume went on from an empty map over
// the run's keyframes, and wrote a manifest of nothing. It is refused, and the folder left as it was.
TEST(MapperCheckpoint, AMapWhoseManifestAndChunkFilesAreAllGoneIsNotResumedEmpty) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  const test::WallSequence seq(10);
  const Config c = small_config();
  const fs::path m_dir = dir / "m";
  {
    Mapper m(m_dir, c, false);
    add_frames(m, seq, 0, 4);
    m.checkpoint({{"next_frame", 4}});
  }
  fs::remove(m_dir / "manifest.txt");
  fs::remove_all(m_dir / "chunks");
  const auto before = contents(m_dir);
  try {
    Mapper m(m_dir, c, true);
    ADD_FAILURE() << "a map without its Gaussians was resumed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("every chunk file"), std::string::npos) << e.what();
  }
  EXPECT_EQ(contents(m_dir), before);
  EXPECT_FALSE(fs::exists(m_dir / "manifest.txt"));
}


std::map<std::string, size_t> contents(const fs::path& folder) {
  std::map<std::string, size_t> out;
  for (const auto& e : fs::recursive_directory_iterator(folder)) {
    if (!e.is_regular_file() || e.path().filename() == "lock") continue;
    std::ifstream f(e.path(), std::ios::binary);
    std::stringstream s;
    s << f.rdbuf();
    out[fs::relative(e.path(), folder).string()] = std::hash<std::string>()(s.str());
  }
  return out;
}

TEST(MapperCheckpoint, ARunEndedByAnErrorLeavesTheFolderAsItsLastCheckpointDid) {
  // --resume on a map with a damaged keyframe file failed, but the keyframes stored before the
  // damage was read stayed behind (keyframes/4.keyframe), as did chunk files written by evictions.
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(10);
  Config c = small_config();
  c.residency.budget_gaussians = 3000;  // evictions write chunks between the checkpoints
  const fs::path b = dir / "b";
  std::map<std::string, size_t> at_checkpoint;
  {
    Mapper m(b, c, false);
    add_frames(m, seq, 0, 4);
    m.checkpoint({{"next_frame", 4}});
    at_checkpoint = contents(b);
    add_frames(m, seq, 4, 9);  // then an error ends the run: no checkpoint
    size_t new_chunk_files = 0;
    for (const auto& [name, hash] : contents(b))
      new_chunk_files += name.rfind("chunks/", 0) == 0 && !at_checkpoint.count(name);
    ASSERT_GT(new_chunk_files, 0u) << "no chunk was evicted after the checkpoint";
  }
  EXPECT_EQ(contents(b), at_checkpoint);
  {
    Mapper m(b, c, true);
    EXPECT_EQ(m.keyframes().size(), 4u);
    add_frames(m, seq, 4, 6);
  }
  EXPECT_EQ(contents(b), at_checkpoint) << "a resumed run that ends without a checkpoint";
}

// An error that ends a run is reported once by whoever catches it; the checkpoint it leaves in flight
// fails for the same cause (here the keyframe files could not be written) and was logged as a
// second error ("[error] mapper: the checkpoint in flight failed"), as if a second fault happened.
TEST(MapperCheckpoint, ACheckpointInFlightWhenAnErrorEndsTheRunIsNotASecondError) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(4);
  const Config c = small_config();
  const fs::path b = dir / "b";
  testing::internal::CaptureStderr();
  try {
    Mapper m(b, c, false);
    add_frames(m, seq, 0, 2);
    m.checkpoint({{"next_frame", 2}});
    fs::remove_all(b / "keyframes");  // the next keyframe's file cannot be written
    add_frames(m, seq, 2, 3);
    m.checkpoint({{"next_frame", 3}}, /*behind=*/true);
    throw Error("the run's own error");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "the run's own error");
  }
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(err.find("[error]"), std::string::npos) << err;
  EXPECT_NE(err.find("the previous one stands"), std::string::npos) << err;
}

TEST(MapperCheckpoint, AKeyframeChunkIndexOfTheWrongTypeIsNamedWithItsFile) {
  // It said only "keyframe chunk index: expected an object, got array".
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(4);
  const Config c = small_config();
  const fs::path b = dir / "b";
  {
    Mapper m(b, c, false);
    add_frames(m, seq, 0, 2);
    m.checkpoint({{"next_frame", 2}});
  }
  nlohmann::json state = read_json_file(b / "run_state.json");
  state["keyframe_chunks"] = {1, 2};
  write_json_atomically(b / "run_state.json", state, false);
  try {
    Mapper m(b, c, true);
    FAIL() << "resumed with a damaged keyframe chunk index";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find((b / "run_state.json").string() + ": 'keyframe_chunks'"),
              std::string::npos)
        << e.what();
  }
}

// A checkpoint written behind training: the folder, copied at any moment after it committed while
// training goes on, resumes to exactly its keyframes, with no Gaussian of a later keyframe.
TEST(MapperCheckpoint, ACheckpointWrittenBehindResumesToItsOwnMoment) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(12);
  Config c = small_config();
  const fs::path b = dir / "b", a = dir / "a";
  {
    Mapper m(b, c, false);
    add_frames(m, seq, 0, 3);
    m.checkpoint({{"next_frame", 3}});
    add_frames(m, seq, 3, 6);
    m.checkpoint({{"next_frame", 6}}, /*behind=*/true);
    // Training goes on (steps finish the checkpoint) until the keyframe list of it is in place.
    size_t next = 6;
    while (read_keyframe_records(b / "keyframes.txt").size() != 6 && next < 11) add_frames(m, seq, next, next + 1), ++next;
    ASSERT_EQ(read_keyframe_records(b / "keyframes.txt").size(), 6u) << "the checkpoint never committed";
    add_frames(m, seq, next, next + 1);
    copy_folder(b, a);  // killed now
  }
  {
    Mapper m(a, c, true);
    EXPECT_EQ(m.keyframes().size(), 6u);
    EXPECT_EQ(m.resumed_state()["next_frame"].get<int>(), 6);
  }
  const auto ids = creators(a);
  ASSERT_FALSE(ids.empty());
  for (uint32_t k : ids) ASSERT_LT(k, 6u) << "a Gaussian of keyframe " << k << " is in the checkpoint";
  std::set<uint32_t> distinct(ids.begin(), ids.end());
  EXPECT_GE(distinct.size(), 5u) << "the keyframes before the checkpoint keep their Gaussians";
}

}  // namespace
}  // namespace chungs
