#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/residency/residency.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
ChunkId cid(int x) { return chunk_id({x, 0, 0}); }

struct Rig {
  test::TempDir dir;
  std::unique_ptr<ChunkStore> store;
  std::unique_ptr<CpuGaussianPool> pool;
  std::unique_ptr<Residency> res;

  // Chunks 0..sizes.size()-1 on disk with the given counts, then a residency over them.
  Rig(std::vector<size_t> sizes, size_t budget, bool async = false, double hysteresis = 0.0) {
    ChunkStoreConfig sc;
    sc.half_moments = sc.half_sh_rest = false;  // these tests compare exact round trips
    sc.durable = false;
    store = std::make_unique<ChunkStore>(dir.path(), sc);
    for (size_t i = 0; i < sizes.size(); ++i) store->save(cid(int(i)), test::random_block(sizes[i], i + 1));
    pool = std::make_unique<CpuGaussianPool>(budget);
    ResidencyConfig rc;
    rc.budget_gaussians = budget;
    rc.async_io = async;
    rc.eviction_hysteresis = hysteresis;
    res = std::make_unique<Residency>(*store, *pool, rc);
  }
  GaussianBlock gathered(ChunkId id) {
    GaussianBlock b;
    pool->gather(res->slots(id), b);
    return b;
  }
  PinResult pin1(ChunkId id) { return res->pin(std::span<const ChunkId>(&id, 1)); }
  void unpin1(ChunkId id) { res->unpin(std::span<const ChunkId>(&id, 1)); }
};
}  // namespace

TEST(Residency, LoadsPinnedChunksExactlyAsStored) {
  Rig r({100, 200, 50}, 1000);
  const std::vector<ChunkId> ids{cid(0), cid(1), cid(2)};
  const PinResult p = r.res->pin(ids);
  EXPECT_TRUE(p.ok) << p.message;
  EXPECT_EQ(p.loaded, 3u);
  EXPECT_EQ(p.pinned_gaussians, 350u);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(test::same_bits(r.gathered(cid(i)), r.store->load(cid(i))));
  EXPECT_EQ(r.res->resident_gaussians(), 350u);
  std::vector<uint32_t> all;
  r.res->append_slots(ids, all);
  EXPECT_EQ(all.size(), 350u);
}

TEST(Residency, WrittenSlotsAreTheAppendedListAndWrongRoomIsRefused) {
  Rig r({100, 200, 50}, 1000);
  const std::vector<ChunkId> ids{cid(2), cid(0), cid(1)};
  ASSERT_TRUE(r.res->pin(ids).ok);
  std::vector<uint32_t> appended;
  r.res->append_slots(ids, appended);
  ASSERT_EQ(r.res->slot_count(ids), 350u);
  std::vector<uint32_t> written(350, 0xFFFFFFFFu);
  r.res->write_slots(ids, written);
  EXPECT_EQ(written, appended);
  std::vector<uint32_t> small(349), large(351);
  EXPECT_THROW(r.res->write_slots(ids, small), Error);
  EXPECT_THROW(r.res->write_slots(ids, large), Error);
}

TEST(Residency, CleanChunkIsDroppedWithoutAWrite) {
  Rig r({300, 300}, 1000);
  r.pin1(cid(0));
  r.unpin1(cid(0));
  const auto before = r.res->stats();
  r.res->evict(cid(0));
  const auto after = r.res->stats();
  EXPECT_EQ(after.saves, before.saves);
  EXPECT_EQ(after.evictions_clean, before.evictions_clean + 1);
  EXPECT_FALSE(r.res->is_resident(cid(0)));
}

TEST(Residency, ModifiedChunkIsWrittenBeforeItsSlotsAreReused) {
  for (bool async : {false, true}) {
    Rig r({300, 300}, 400, async);
    r.pin1(cid(0));
    const auto slots = r.res->slots(cid(0));
    for (uint32_t s : slots) r.pool->params().opacity[s] += 1.0f;
    r.res->mark_dirty(cid(0));
    const GaussianBlock modified = r.gathered(cid(0));
    r.unpin1(cid(0));
    // Chunk 1 needs chunk 0's slots: chunk 0 goes to disk (or the write-behind queue) first.
    EXPECT_TRUE(r.pin1(cid(1)).ok);
    EXPECT_FALSE(r.res->is_resident(cid(0)));
    r.unpin1(cid(1));
    EXPECT_TRUE(r.pin1(cid(0)).ok);
    EXPECT_TRUE(test::same_bits(r.gathered(cid(0)), modified)) << (async ? "async" : "sync");
    r.res->flush();
    EXPECT_TRUE(test::same_bits(r.store->load(cid(0)), modified));
    EXPECT_EQ(r.res->stats().evictions_dirty, 1u);
  }
}

TEST(Residency, FlushGathersChunksInPortionsAndWritesEachExactly) {
  // 40 chunks of 97-296 Gaussians (~8 k) with a 10 000 budget: flush gathers portions of ~2 500
  // Gaussians at a time, so chunks are split out of several gathers, across portion edges.
  std::vector<size_t> sizes;
  for (size_t i = 0; i < 40; ++i) sizes.push_back(97 + (i * 37) % 200);
  Rig r(sizes, 10'000, /*async=*/true);
  std::vector<GaussianBlock> modified;
  for (size_t i = 0; i < sizes.size(); ++i) {
    r.pin1(cid(int(i)));
    for (uint32_t s : r.res->slots(cid(int(i)))) r.pool->params().opacity[s] += 0.5f + float(i);
    r.res->mark_dirty(cid(int(i)));
    modified.push_back(r.gathered(cid(int(i))));
    r.unpin1(cid(int(i)));
  }
  r.res->flush();
  for (size_t i = 0; i < sizes.size(); ++i)
    EXPECT_TRUE(test::same_bits(r.store->load(cid(int(i))), modified[i])) << "chunk " << i;
}

TEST(Residency, EvictsLeastRecentlyUsedFirstAndNoMoreThanNeeded) {
  Rig r({300, 300, 300, 300, 100}, 1000);
  for (int i : {0, 1, 2}) {
    r.pin1(cid(i));
    r.unpin1(cid(i));
  }
  r.pin1(cid(0));  // 0 is now the most recent; 1 is the oldest
  r.unpin1(cid(0));
  const PinResult p = r.pin1(cid(3));  // needs 200 more: evict exactly one chunk, the oldest
  EXPECT_TRUE(p.ok);
  EXPECT_EQ(p.evicted, 1u);
  EXPECT_FALSE(r.res->is_resident(cid(1)));
  EXPECT_TRUE(r.res->is_resident(cid(0)));
  EXPECT_TRUE(r.res->is_resident(cid(2)));
  EXPECT_EQ(r.res->resident_gaussians(), 900u);
}

TEST(Residency, HysteresisEvictsAMarginBeyondTheShortfall) {
  Rig r({300, 300, 300, 300}, 1000, false, 0.05);
  for (int i : {0, 1, 2}) {
    r.pin1(cid(i));
    r.unpin1(cid(i));
  }
  // Needs 200, target 200 + 50: chunk 0 (300) covers it; chunk 1 stays.
  EXPECT_EQ(r.pin1(cid(3)).evicted, 1u);
  EXPECT_TRUE(r.res->is_resident(cid(1)));
}

TEST(Residency, PinnedChunksAreNeverEvicted) {
  Rig r({400, 400, 400}, 1000);
  r.pin1(cid(0));
  r.pin1(cid(1));
  r.unpin1(cid(1));
  EXPECT_TRUE(r.pin1(cid(2)).ok);
  EXPECT_TRUE(r.res->is_resident(cid(0)));
  EXPECT_FALSE(r.res->is_resident(cid(1)));
  EXPECT_THROW(r.res->evict(cid(0)), Error);
}

TEST(Residency, SaysByHowMuchThePinnedSetExceedsTheBudget) {
  Rig r({600, 500, 100}, 1000);
  r.pin1(cid(2));
  const std::vector<ChunkId> ids{cid(0), cid(1)};
  const PinResult p = r.res->pin(ids);
  EXPECT_FALSE(p.ok);
  EXPECT_EQ(p.pinned_gaussians, 1200u);
  EXPECT_EQ(p.over_budget, 200u);
  EXPECT_NE(p.message.find("200 over the budget of 1000"), std::string::npos) << p.message;
  // Nothing changed: no thrashing, nothing loaded.
  EXPECT_FALSE(r.res->is_resident(cid(0)));
  EXPECT_FALSE(r.res->is_resident(cid(1)));
  EXPECT_EQ(r.res->pinned_gaussians(), 100u);
  EXPECT_EQ(r.res->stats().loads, 1u);
}

TEST(Residency, UnknownChunksAreSkippedAndListed) {
  Rig r({10}, 100);
  const std::vector<ChunkId> ids{cid(0), cid(7)};
  const PinResult p = r.res->pin(ids);
  EXPECT_TRUE(p.ok);
  EXPECT_EQ(p.unknown, std::vector<ChunkId>{cid(7)});
  EXPECT_TRUE(r.res->is_pinned(cid(0)));
}

TEST(Residency, AddCreatesChunksAndRefusesWhenPinnedLeaveNoRoom) {
  Rig r({500}, 1000);
  r.pin1(cid(0));
  const GaussianBlock fresh = test::random_block(300, 9);
  PinResult p = r.res->add(cid(5), fresh);
  EXPECT_TRUE(p.ok);
  EXPECT_EQ(r.res->count(cid(5)), 300u);
  EXPECT_TRUE(r.res->is_dirty(cid(5)));
  EXPECT_TRUE(test::same_bits(r.gathered(cid(5)), fresh));
  p = r.res->add(cid(0), test::random_block(600, 10));
  EXPECT_FALSE(p.ok);
  EXPECT_EQ(p.over_budget, 100u);
  EXPECT_EQ(r.res->count(cid(0)), 500u);
  // Room is made by evicting the unpinned new chunk, which is written, not lost.
  EXPECT_TRUE(r.res->add(cid(0), test::random_block(400, 11)).ok);
  EXPECT_FALSE(r.res->is_resident(cid(5)));
  EXPECT_EQ(r.res->pinned_gaussians(), 900u);
  r.res->flush();
  EXPECT_TRUE(test::same_bits(r.store->load(cid(5)), fresh));
}

TEST(Residency, PruningToEmptyRemovesTheChunkFromTheMap) {
  Rig r({50, 60}, 200);
  r.pin1(cid(0));
  const auto slots = r.res->slots(cid(0));
  const std::vector<uint32_t> some(slots.begin(), slots.begin() + 20);
  r.res->remove_slots(cid(0), some);
  EXPECT_EQ(r.res->count(cid(0)), 30u);
  EXPECT_EQ(r.res->pinned_gaussians(), 30u);
  EXPECT_THROW(r.res->remove_slots(cid(0), some), Error);  // no longer its slots
  const auto rest = r.res->slots(cid(0));
  r.res->remove_slots(cid(0), std::vector<uint32_t>(rest.begin(), rest.end()));
  r.unpin1(cid(0));
  r.res->evict(cid(0));
  r.res->flush();
  EXPECT_FALSE(r.res->contains(cid(0)));
  EXPECT_FALSE(r.store->contains(cid(0)));
  EXPECT_EQ(r.pool->used(), 0u);
}

TEST(Residency, WrittenPlacesLeaveTheirChunksAsRemoveSlotsWouldHaveIt) {
  // Two rigs with the same chunks: one removes lists of slots chunk by chunk, the other the same Gaussians
  // by their places in the slot list of a view (chunks 2, 0, 1 in that order, as a step writes it).
  Rig a({50, 60, 40}, 300), b({50, 60, 40}, 300);
  for (Rig* r : {&a, &b})
    for (int c = 0; c < 3; ++c) r->pin1(cid(c));
  const std::vector<ChunkId> view{cid(2), cid(0), cid(1)};
  std::vector<uint32_t> written(b.res->slot_count(view));
  b.res->write_slots(view, written);
  std::vector<uint32_t> places, from0;
  for (uint32_t i = 40; i < 90; i += 3) places.push_back(i), from0.push_back(written[i]);  // within chunk 0
  places.push_back(90 + 5);                                                                // one of chunk 1's
  places.push_back(uint32_t(written.size()) - 1);                                          // chunk 1's last
  const std::vector<uint32_t> from1{written[95], written.back()};

  // Refused, changing nothing: not ascending, past the list, a chunk named twice.
  EXPECT_THROW(b.res->remove_written_slots(view, std::vector<uint32_t>{7, 7}), Error);
  EXPECT_THROW(b.res->remove_written_slots(view, std::vector<uint32_t>{9, 3}), Error);
  EXPECT_THROW(b.res->remove_written_slots(view, std::vector<uint32_t>{uint32_t(written.size())}), Error);
  EXPECT_THROW(b.res->remove_written_slots(std::vector<ChunkId>{cid(0), cid(0)}, std::vector<uint32_t>{1}),
               Error);
  EXPECT_EQ(b.res->count(cid(0)), 50u);
  EXPECT_FALSE(b.res->is_dirty(cid(0)));

  a.res->remove_slots(cid(0), from0);
  a.res->remove_slots(cid(1), from1);
  EXPECT_EQ(b.res->remove_written_slots(view, places), places.size());
  for (int c = 0; c < 3; ++c) EXPECT_EQ(a.res->slots(cid(c)), b.res->slots(cid(c))) << "chunk " << c;
  EXPECT_EQ(b.res->count(cid(0)), 50u - from0.size());
  EXPECT_EQ(b.res->count(cid(1)), 58u);
  EXPECT_TRUE(b.res->is_dirty(cid(0)));
  EXPECT_TRUE(b.res->is_dirty(cid(1)));
  EXPECT_FALSE(b.res->is_dirty(cid(2)));
  EXPECT_EQ(b.res->pinned_gaussians(), 150u - from0.size() - 2);
  EXPECT_EQ(b.pool->used(), 150u - from0.size() - 2);
  EXPECT_EQ(b.res->remove_written_slots(view, {}), 0u);
  // Freed slots are reused in the same order on both.
  EXPECT_TRUE(a.res->add(cid(7), test::random_block(30, 3)).ok);
  EXPECT_TRUE(b.res->add(cid(7), test::random_block(30, 3)).ok);
  EXPECT_EQ(a.res->slots(cid(7)), b.res->slots(cid(7)));
}

TEST(Residency, PrefetchedChunksLoadWithoutWaiting) {
  Rig r({200, 200, 200, 200}, 1000, true);
  const std::vector<ChunkId> ids{cid(0), cid(1), cid(2), cid(3)};
  r.res->prefetch(ids);
  for (int i = 0; i < 500 && r.res->stats().loads < 4; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ASSERT_EQ(r.res->stats().loads, 4u);
  EXPECT_TRUE(r.res->pin(ids).ok);
  const IoStats s = r.res->stats();
  EXPECT_EQ(s.pool_loads, 4u);
  EXPECT_EQ(s.prefetch_hits, 4u);
  EXPECT_EQ(s.sync_loads, 0u);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(test::same_bits(r.gathered(cid(i)), r.store->load(cid(i))));
}

namespace {
// The rig's residency again, with background I/O, a budget of 1000 and this read-ahead limit.
void with_read_ahead(Rig& r, size_t prefetch_max) {
  ResidencyConfig rc;
  rc.budget_gaussians = 1000;
  rc.async_io = true;
  rc.prefetch_max_gaussians = prefetch_max;
  r.res.reset();
  r.res = std::make_unique<Residency>(*r.store, *r.pool, rc);
}
void wait_for_loads(const Rig& r, uint64_t n) {
  for (int i = 0; i < 1000 && r.res->stats().loads < n; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
}
}  // namespace

// Picks several steps ahead name more chunks than the read-ahead holds: the reads for the nearest
// steps stay and the rest wait for room (dropping the oldest reads, as before, threw away exactly
// those the next pin needed).
TEST(Residency, AFullReadAheadKeepsTheReadsForTheNearestStepsAndResumesOnceTheyAreTaken) {
  Rig r({200, 200, 200, 200}, 1000, true);
  with_read_ahead(r, 400);  // two of its 200-Gaussian chunks
  const std::vector<ChunkId> ids{cid(0), cid(1), cid(2), cid(3)};
  r.res->prefetch(ids);
  wait_for_loads(r, 2);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // time for reads that must not happen
  EXPECT_EQ(r.res->stats().loads, 2u);
  const std::vector<ChunkId> near{cid(0), cid(1)}, far{cid(2), cid(3)};
  ASSERT_TRUE(r.res->pin(near).ok);
  EXPECT_EQ(r.res->stats().prefetch_hits, 2u);
  EXPECT_EQ(r.res->stats().sync_loads, 0u);
  r.res->prefetch(far);  // the next step's prediction: the rest fits now
  wait_for_loads(r, 4);
  ASSERT_TRUE(r.res->pin(far).ok);
  const IoStats s = r.res->stats();
  EXPECT_EQ(s.prefetch_hits, 4u);
  EXPECT_EQ(s.sync_loads, 0u);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(test::same_bits(r.gathered(cid(i)), r.store->load(cid(i))));
}

TEST(Residency, ReadsAheadThatTheLatestPredictionNoLongerNamesGiveWay) {
  Rig r({200, 200, 200, 200}, 1000, true);
  with_read_ahead(r, 400);  // two of its 200-Gaussian chunks
  r.res->prefetch(std::vector<ChunkId>{cid(0), cid(1)});
  wait_for_loads(r, 2);
  const std::vector<ChunkId> now{cid(2), cid(3)};
  r.res->prefetch(now);
  wait_for_loads(r, 4);
  ASSERT_TRUE(r.res->pin(now).ok);
  EXPECT_EQ(r.res->stats().prefetch_hits, 2u);
  EXPECT_EQ(r.res->stats().sync_loads, 0u);
}

// The prefetch hint names the chunks of the next steps: eviction takes the others first, oldest
// first, and of the named ones (when nothing else makes room) the one needed last.
TEST(Residency, EvictionSparesTheChunksTheNextStepsNeedAndTakesTheOneNeededLastFirst) {
  Rig r({200, 200, 200, 200, 200}, 600);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(r.pin1(cid(i)).ok);
    r.unpin1(cid(i));
  }
  r.res->prefetch(std::vector<ChunkId>{cid(0)});  // the oldest is needed next
  ASSERT_TRUE(r.pin1(cid(3)).ok);
  r.unpin1(cid(3));
  EXPECT_TRUE(r.res->is_resident(cid(0)));
  EXPECT_FALSE(r.res->is_resident(cid(1)));
  // All resident chunks named: the one named last goes, whatever its age.
  r.res->prefetch(std::vector<ChunkId>{cid(3), cid(0), cid(2)});
  ASSERT_TRUE(r.pin1(cid(4)).ok);
  EXPECT_TRUE(r.res->is_resident(cid(0)));
  EXPECT_FALSE(r.res->is_resident(cid(2)));
  EXPECT_TRUE(r.res->is_resident(cid(3)));
  r.unpin1(cid(4));
}

TEST(Residency, SetBudgetEvictsDownAndRefusesBelowThePinnedSet) {
  Rig r({300, 300, 300}, 1000);
  const std::vector<ChunkId> ids{cid(0), cid(1), cid(2)};
  r.res->pin(ids);
  r.res->unpin(std::vector<ChunkId>{cid(1), cid(2)});
  EXPECT_TRUE(r.res->set_budget(650));
  EXPECT_LE(r.res->resident_gaussians(), 650u);
  EXPECT_TRUE(r.res->is_resident(cid(0)));
  EXPECT_FALSE(r.res->set_budget(200));
  EXPECT_EQ(r.res->budget(), 650u);
  EXPECT_THROW(r.res->set_budget(2000), Error);  // beyond the pool
}

TEST(Residency, RejectsAPoolSmallerThanTheBudget) {
  test::TempDir dir;
  ChunkStore store(dir.path());
  CpuGaussianPool pool(10);
  ResidencyConfig rc;
  rc.budget_gaussians = 11;
  EXPECT_THROW(Residency(store, pool, rc), Error);
}

TEST(Residency, UnpinOfAnUnpinnedChunkIsAnErrorAndChangesNothing) {
  Rig r({10, 10}, 100);
  r.pin1(cid(0));
  r.pin1(cid(1));
  r.unpin1(cid(1));
  EXPECT_THROW(r.res->unpin(std::vector<ChunkId>{cid(0), cid(1)}), Error);
  EXPECT_TRUE(r.res->is_pinned(cid(0)));
}

// A write behind that failed once and succeeded when a flush retried it left no trace: the run went
// on with exit status 0 and nobody learnt that the disk had refused a write.
TEST(Residency, AFailedBackgroundWriteThatARetryMendsIsStillReported) {
  Rig r({100, 100}, 1000, true);
  r.pin1(cid(0));
  r.res->mark_dirty(cid(0));
  const GaussianBlock modified = r.gathered(cid(0));
  r.unpin1(cid(0));
  const auto chunks = r.dir / "chunks";
  std::filesystem::rename(chunks, r.dir / "chunks.away");
  std::ofstream(chunks) << "not a folder";
  r.res->evict(cid(0));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the background write fails meanwhile
  std::filesystem::remove(chunks);
  std::filesystem::rename(r.dir / "chunks.away", chunks);
  testing::internal::CaptureStderr();
  r.res->flush();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("trying it again"), std::string::npos) << err;
  EXPECT_NE(err.find("chunks"), std::string::npos) << err;
  EXPECT_TRUE(test::same_bits(r.store->load(cid(0)), modified));
}

// A chunk read ahead whose read failed (EIO once, in the fault sweep) was dropped with a debug line;
// the load when it was needed read it again and succeeded, so the run went on and nothing said that
// the disk had failed a read.
TEST(Residency, AFailedReadAheadIsReportedAndTheChunkIsReadAgainWhenNeeded) {
  Rig r({100, 100}, 1000, true);
  with_read_ahead(r, 1000);
  const GaussianBlock stored = r.store->load(cid(1));
  const auto chunks = r.dir / "chunks";
  std::filesystem::rename(chunks, r.dir / "chunks.away");
  std::ofstream(chunks) << "not a folder";
  testing::internal::CaptureStderr();
  const ChunkId ahead = cid(1);
  r.res->prefetch(std::span<const ChunkId>(&ahead, 1));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the read ahead fails meanwhile
  const std::string err = testing::internal::GetCapturedStderr();
  std::filesystem::remove(chunks);
  std::filesystem::rename(r.dir / "chunks.away", chunks);
  EXPECT_NE(err.find("reading ahead"), std::string::npos) << err;
  EXPECT_NE(err.find(chunk_name(ahead)), std::string::npos) << err;
  ASSERT_TRUE(r.pin1(ahead).ok);
  EXPECT_TRUE(test::same_bits(r.gathered(ahead), stored));
  r.unpin1(ahead);
}

TEST(Residency, FailedBackgroundWriteKeepsTheDataReportsTheErrorAndRetries) {
  Rig r({100, 100}, 1000, true);
  r.pin1(cid(0));
  for (uint32_t s : r.res->slots(cid(0))) r.pool->params().opacity[s] = 42.0f;
  r.res->mark_dirty(cid(0));
  const GaussianBlock modified = r.gathered(cid(0));
  r.unpin1(cid(0));
  // Make every chunk write fail: the chunk folder becomes a plain file.
  const auto chunks = r.dir / "chunks";
  std::filesystem::rename(chunks, r.dir / "chunks.away");
  std::ofstream(chunks) << "not a folder";
  r.res->evict(cid(0));  // queued; the write fails in the background
  try {
    r.res->flush();
    FAIL() << "the failed write must be reported";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("chunks"), std::string::npos) << e.what();
  }
  // The modified data was not lost: a load gets the queued block.
  EXPECT_TRUE(r.pin1(cid(0)).ok);
  EXPECT_TRUE(test::same_bits(r.gathered(cid(0)), modified));
  EXPECT_GE(r.res->stats().write_behind_hits, 1u);
  r.unpin1(cid(0));
  r.res->evict(cid(0));
  // The disk comes back: the next flush retries and succeeds.
  std::filesystem::remove(chunks);
  std::filesystem::rename(r.dir / "chunks.away", chunks);
  r.res->flush();
  EXPECT_TRUE(test::same_bits(r.store->load(cid(0)), modified));
}

// The automatic sizes of the queues for chunks in flight: at least one large view (160 k) read ahead
// and queued for writing, within the budget (half of it for writes), and 1/32 and 1/8 of a large one.
TEST(ResidencyConfig, ChunksInFlightHoldALargeViewWithinTheBudget) {
  const auto in_flight = [](size_t budget, size_t prefetch = 0, size_t write_behind = 0) {
    ResidencyConfig c;
    c.budget_gaussians = budget;
    c.prefetch_max_gaussians = prefetch;
    c.write_behind_max_gaussians = write_behind;
    return in_flight_max_gaussians(c) - checkpoint_memory_limit(budget);
  };
  EXPECT_EQ(in_flight(300'000), 160'000u + 150'000u);
  EXPECT_EQ(in_flight(1'500'000), 160'000u + 187'500u);
  EXPECT_EQ(in_flight(8'000'000), 250'000u + 1'000'000u);
  EXPECT_EQ(in_flight(100'000), 100'000u + 50'000u);
  EXPECT_EQ(in_flight(12'000), 12'000u + 10'000u);
  EXPECT_EQ(in_flight(300'000, 7'000, 9'000), 7'000u + 9'000u);  // set ones are kept
}
