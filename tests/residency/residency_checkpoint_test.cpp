// Checkpoints written behind the caller: whatever the caller does meanwhile (changing pinned
// chunks, adding, pruning, evicting under budget pressure), the committed map is the map of the
// checkpoint's moment, bit for bit, and the live map is not disturbed.
#include <gtest/gtest.h>

#include <map>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/residency/residency.hpp"
#include "chungs/store/atomic_file.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
ChunkId cid(int x) { return chunk_id({x, 0, 0}); }

ChunkStoreConfig rollback_config() {
  ChunkStoreConfig c;
  c.half_moments = c.half_sh_rest = false;  // these tests compare exact round trips
  c.durable = false;
  c.adopt_uncommitted = false;
  return c;
}

std::map<ChunkId, GaussianBlock> committed_map(const fs::path& folder, const fs::path& copy) {
  fs::create_directories(copy / "chunks");
  // The I/O thread may be writing (temporary files) or deleting superseded files meanwhile.
  for (const auto& e : fs::directory_iterator(folder / "chunks")) {
    std::error_code ec;
    fs::copy_file(e.path(), copy / "chunks" / e.path().filename(), ec);
  }
  fs::copy_file(folder / "manifest.txt", copy / "manifest.txt");
  ChunkStore s(copy, rollback_config());
  std::map<ChunkId, GaussianBlock> m;
  for (ChunkId id : s.ids()) m[id] = s.load(id);
  return m;
}

// Every chunk of the live map, each pinned in turn: a chunk evicted a moment ago may still be
// queued for writing, and its file on disk older.
std::map<ChunkId, GaussianBlock> live_map(Residency& res, GaussianPool& pool) {
  std::vector<ChunkId> ids;
  for (const auto& [id, n] : res.catalogue())
    if (n > 0) ids.push_back(id);
  std::map<ChunkId, GaussianBlock> m;
  for (ChunkId id : ids) {
    const ChunkId one[] = {id};
    EXPECT_TRUE(res.pin(one).ok);
    pool.gather(res.slots(id), m[id]);
    res.unpin(one);
  }
  return m;
}

void expect_same_maps(const std::map<ChunkId, GaussianBlock>& got, const std::map<ChunkId, GaussianBlock>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (const auto& [id, b] : want) {
    ASSERT_TRUE(got.count(id)) << chunk_name(id);
    EXPECT_TRUE(test::same_bits(got.at(id), b)) << chunk_name(id);
  }
}

// Changes every Gaussian of a pinned chunk, as an optimiser step would.
void train(Residency& res, CpuGaussianPool& pool, ChunkId id, float by) {
  const ChunkId one[] = {id};
  ASSERT_TRUE(res.pin(one).ok);
  for (uint32_t s : res.slots(id)) {
    pool.params().opacity[s] += by;
    pool.storage().adam_m.mean[3 * s] -= by;
  }
  res.mark_dirty(id);
  res.unpin(one);
}
}  // namespace

TEST(ResidencyCheckpoint, CommitsTheMapOfItsMomentWhateverHappensMeanwhile) {
  for (bool async : {false, true}) {
    SCOPED_TRACE(async ? "background I/O" : "synchronous I/O");
    test::TempDir dir, copy;
    ChunkStore store(dir.path(), rollback_config());
    CpuGaussianPool pool(4000);
    ResidencyConfig rc;
    rc.budget_gaussians = 4000;
    rc.async_io = async;
    rc.checkpoint_threads = 3;
    Residency res(store, pool, rc);
    for (int x = 0; x < 12; ++x) ASSERT_TRUE(res.add(cid(x), test::random_block(300 + 10 * x, x + 1)).ok);
    res.flush();
    for (int x = 5; x < 12; ++x) train(res, pool, cid(x), 0.25f);
    const auto at_moment = live_map(res, pool);

    std::vector<std::string> calls;
    res.begin_checkpoint([&] { calls.push_back("before"); }, [&] { calls.push_back("after"); });
    EXPECT_TRUE(res.checkpoint_in_flight());
    // Meanwhile: train what the checkpoint still needs, add to a chunk and make new ones (which
    // evicts under the budget), prune, move on a step at a time.
    train(res, pool, cid(11), 1.0f);
    ASSERT_TRUE(res.add(cid(10), test::random_block(40, 77)).ok);
    const ChunkId nine[] = {cid(9)};
    ASSERT_TRUE(res.pin(nine).ok);
    const std::vector<uint32_t> prune(res.slots(cid(9)).begin(), res.slots(cid(9)).begin() + 7);
    res.remove_slots(cid(9), prune);
    res.unpin(nine);
    for (int x = 12; x < 20; ++x) {
      ASSERT_TRUE(res.add(cid(x), test::random_block(350, x + 1)).ok);
      train(res, pool, cid(x - 4), 0.5f);
      res.advance_checkpoint();
    }
    EXPECT_GT(store.counters().evictions_dirty.load(), 0u) << "the budget forced writes meanwhile";
    for (int k = 0; k < 1000 && res.checkpoint_in_flight(); ++k) {
      res.advance_checkpoint();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_FALSE(res.checkpoint_in_flight()) << "advance_checkpoint() completes it";
    EXPECT_EQ(calls, (std::vector<std::string>{"before", "after"}));
    {
      SCOPED_TRACE("the checkpoint's map");
      expect_same_maps(committed_map(dir.path(), copy.path() / "1"), at_moment);
    }

    // The live map went on undisturbed: after a plain flush the folder holds it.
    const auto now = live_map(res, pool);
    res.flush();
    expect_same_maps(committed_map(dir.path(), copy.path() / "2"), now);
    const IoStats s = store.counters().snapshot();
    EXPECT_EQ(s.checkpoints_behind, 1u);
    EXPECT_GT(s.checkpoint_behind_ms, 0.0);
  }
}

TEST(ResidencyCheckpoint, AFailedCheckpointKeepsThePreviousOneAndReachesTheCaller) {
  test::TempDir dir, copy;
  ChunkStore store(dir.path(), rollback_config());
  CpuGaussianPool pool(2000);
  ResidencyConfig rc;
  rc.budget_gaussians = 2000;
  Residency res(store, pool, rc);
  for (int x = 0; x < 4; ++x) ASSERT_TRUE(res.add(cid(x), test::random_block(100, x + 1)).ok);
  res.flush();
  const auto before = live_map(res, pool);
  train(res, pool, cid(2), 1.0f);
  res.begin_checkpoint([] { fail("keyframe list could not be written"); }, [] {});
  train(res, pool, cid(3), 1.0f);
  EXPECT_THROW(res.finish_checkpoint(), Error);
  EXPECT_FALSE(res.checkpoint_in_flight());
  expect_same_maps(committed_map(dir.path(), copy.path() / "1"), before);
  // The next checkpoint works, and one finished by the next begin is not lost either.
  res.begin_checkpoint([] {}, [] {});
  const auto at_moment = live_map(res, pool);
  train(res, pool, cid(0), 2.0f);
  res.finish_checkpoint();
  expect_same_maps(committed_map(dir.path(), copy.path() / "2"), at_moment);
}

namespace {
size_t chunk_files(const fs::path& folder) {
  size_t n = 0;
  for (const auto& e : fs::directory_iterator(folder / "chunks"))
    if (e.path().extension() == ".chunk") ++n;
  return n;
}
}  // namespace

TEST(ResidencyCheckpoint, WritesOnlyWhatChangedSinceTheLastOne) {
  for (bool async : {false, true}) {
    SCOPED_TRACE(async ? "background I/O" : "synchronous I/O");
    test::TempDir dir, copy;
    ChunkStore store(dir.path(), rollback_config());
    CpuGaussianPool pool(4000);
    ResidencyConfig rc;
    rc.budget_gaussians = 4000;
    rc.async_io = async;
    Residency res(store, pool, rc);
    for (int x = 0; x < 8; ++x) ASSERT_TRUE(res.add(cid(x), test::random_block(200 + 10 * x, x + 1)).ok);
    res.flush();  // every chunk has a live file that the checkpoints below supersede
    for (int x = 0; x < 8; ++x) train(res, pool, cid(x), 0.25f);
    auto saves = [&] { return store.counters().saves.load(); };

    const uint64_t s0 = saves();
    res.begin_checkpoint([] {}, [] {});
    train(res, pool, cid(6), 0.5f);  // changed after its copy: stays modified
    res.finish_checkpoint();
    EXPECT_EQ(saves() - s0, 8u);
    for (int x = 0; x < 8; ++x) EXPECT_EQ(res.is_dirty(cid(x)), x == 6) << x;

    train(res, pool, cid(2), 1.0f);
    const auto at_moment = live_map(res, pool);
    const uint64_t s1 = saves();
    res.begin_checkpoint([] {}, [] {});
    res.finish_checkpoint();
    EXPECT_EQ(saves() - s1, 2u) << "only the two chunks changed since the last checkpoint";
    expect_same_maps(committed_map(dir.path(), copy.path() / "1"), at_moment);

    // An adopted chunk is evicted without a write and reads back as it was.
    const uint64_t s2 = saves(), clean = store.counters().evictions_clean.load();
    res.evict(cid(3));
    EXPECT_EQ(store.counters().evictions_clean.load(), clean + 1);
    EXPECT_EQ(saves(), s2);
    expect_same_maps(live_map(res, pool), at_moment);

    // The live files the checkpoints replaced are gone: one file per chunk once committed.
    res.flush();
    EXPECT_EQ(chunk_files(dir.path()), 8u);
    expect_same_maps(committed_map(dir.path(), copy.path() / "2"), at_moment);
  }
}

namespace {
void slow_write(const fs::path&, FileEvent event) {
  if (event == FileEvent::Written) std::this_thread::sleep_for(std::chrono::milliseconds(4));
}
}  // namespace

// Chunks copied out because they are about to change (here: pruned) wait for room in the checkpoint's
// queue, so the checkpoint, the write-behind and the read-ahead together stay inside their fixed pool of
// host memory however fast the steps change chunks and however slow the disk is.
TEST(ResidencyCheckpoint, CopiesForChangedChunksStayInsideTheInFlightPool) {
  test::TempDir dir, copy;
  ChunkStore store(dir.path(), rollback_config());
  CpuGaussianPool pool(30000);
  ResidencyConfig rc;
  rc.budget_gaussians = 30000;
  rc.prefetch_max_gaussians = rc.write_behind_max_gaussians = 2000;
  rc.checkpoint_threads = 1;
  Residency res(store, pool, rc);
  const size_t room = res.in_flight_blocks().capacity_bytes() / kBlockBytesPerGaussian;
  ASSERT_LT(room, 20000u) << "the test needs more modified Gaussians than the pool holds";
  for (int x = 0; x < 25; ++x) ASSERT_TRUE(res.add(cid(x), test::random_block(1000, x + 1)).ok);
  res.flush();
  for (int x = 0; x < 25; ++x) train(res, pool, cid(x), 0.25f);
  const auto at_moment = live_map(res, pool);
  set_file_event_hook(slow_write);
  res.begin_checkpoint([] {}, [] {});
  for (int x = 0; x < 25; ++x) {
    const ChunkId one[] = {cid(x)};
    ASSERT_TRUE(res.pin(one).ok);
    const std::vector<uint32_t> gone(res.slots(cid(x)).begin(), res.slots(cid(x)).begin() + 10);
    res.remove_slots(cid(x), gone);
    res.unpin(one);
  }
  res.finish_checkpoint();
  set_file_event_hook(nullptr);
  EXPECT_EQ(res.in_flight_blocks().heap_blocks(), 0u)
      << "peak " << res.in_flight_blocks().peak_used_bytes() << " of " << res.in_flight_blocks().capacity_bytes()
      << " bytes";
  expect_same_maps(committed_map(dir.path(), copy.path() / "1"), at_moment);
}

// The final checkpoint of a short GPU run took 1.0-1.4 s and nothing said which part: gathering out of
// the pool, writing, or the commit. The counters split it.
TEST(ResidencyCheckpoint, AFlushSaysWhereItsTimeWent) {
  test::TempDir dir;
  ChunkStoreConfig sc = rollback_config();
  sc.durable = true;  // the commit flushes files and folder
  ChunkStore store(dir.path(), sc);
  CpuGaussianPool pool(4000);
  ResidencyConfig rc;
  rc.budget_gaussians = 4000;
  ASSERT_TRUE(rc.async_io);
  ASSERT_GT(rc.flush_threads, 1);  // the path that gathers a portion at a time
  Residency res(store, pool, rc);
  for (int x = 0; x < 12; ++x) ASSERT_TRUE(res.add(cid(x), test::random_block(300, x + 1)).ok);
  res.flush();
  const IoStats a = store.counters().snapshot();
  EXPECT_GT(a.flush_gather_ms, 0.0);
  EXPECT_GT(a.flush_commit_ms, 0.0);
  EXPECT_LE(a.flush_gather_ms + a.flush_commit_ms, a.checkpoint_ms);
  EXPECT_EQ(a.saves, 12u);

  // Nothing changed since: no gather, only the commit.
  res.flush();
  const IoStats b = store.counters().snapshot() - a;
  EXPECT_EQ(b.flush_gather_ms, 0.0);
  EXPECT_GT(b.flush_commit_ms, 0.0);
  EXPECT_EQ(b.saves, 0u);
}
