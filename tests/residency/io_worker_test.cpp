// IoWorker over a pool for chunks in flight: the read-ahead stops where the pool has no room (it
// never takes the heap for a guess), queued writes go on when the pool is full (from the heap,
// counted), and every chunk still comes back as it was stored.
#include "chungs/residency/io_worker.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {

ChunkStoreConfig exact() {
  ChunkStoreConfig c;
  c.half_moments = c.half_sh_rest = false;  // exact round trips
  c.durable = false;
  return c;
}
ChunkId cid(int x) { return chunk_id({x, 1, 0}); }

GaussianBlock as_block(const HostBlock& h) {
  GaussianBlock g;
  g.sh_degree = h.sh_degree();
  g.resize(h.size());
  copy_gaussians(h.arrays(), 0, h.size(), block_arrays(g));
  return g;
}

// Waits (a while at most) until `done` holds; the caller checks it again.
template <typename F>
void wait_for(F done) {
  for (int i = 0; i < 1000 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

}  // namespace

TEST(IoWorker, ReadAheadStopsWhereThePoolHasNoRoomAndEveryChunkStillLoads) {
  test::TempDir dir;
  ChunkStore store(dir.path(), exact());
  constexpr int kChunks = 10;
  constexpr size_t kCount = 500;
  for (int x = 0; x < kChunks; ++x) store.save(cid(x), test::random_block(kCount, uint64_t(x) + 1));
  HostBlockPool blocks(3 * HostBlockPool::block_bytes(kCount));  // room for three chunks
  {
    IoWorker io(store, blocks, true, 100 * kCount, 100 * kCount);
    std::vector<std::pair<ChunkId, uint64_t>> wanted;
    for (int x = 0; x < kChunks; ++x) wanted.emplace_back(cid(x), kCount);
    io.prefetch(wanted);
    wait_for([&] { return io.staged_gaussians() >= 3 * kCount; });
    // Reading the rest ahead takes moments from the page cache; give it the time to go wrong.
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_EQ(io.staged_gaussians(), 3 * kCount);
    EXPECT_EQ(blocks.heap_blocks(), 0u);
    int from_memory = 0;
    for (int x = 0; x < kChunks; ++x) {
      IoWorker::Source src;
      const IoWorker::Block b = io.take(cid(x), &src);
      from_memory += src == IoWorker::Source::Prefetched && b->in_pool();
      EXPECT_TRUE(test::same_bits(as_block(*b), store.load(cid(x)))) << "chunk " << x;
    }
    EXPECT_EQ(from_memory, 3);
  }
  EXPECT_EQ(blocks.used_bytes(), 0u);
}

TEST(IoWorker, WritesBehindGoOnWhenThePoolIsFullAndLoadsSeeTheQueuedContent) {
  test::TempDir dir;
  ChunkStore store(dir.path(), exact());
  constexpr size_t kCount = 300;
  HostBlockPool blocks(2 * HostBlockPool::block_bytes(kCount));
  std::vector<GaussianBlock> written;
  std::vector<IoWorker::Block> held;  // also the caller's (a checkpoint's copy): none is freed meanwhile
  {
    IoWorker io(store, blocks, true, 100 * kCount, 100 * kCount);
    for (int x = 0; x < 6; ++x) {
      written.push_back(test::random_block(kCount, uint64_t(x) + 50));
      std::shared_ptr<HostBlock> b = blocks.make(kCount, 3);
      copy_gaussians(block_arrays(written.back()), 0, kCount, b->arrays());
      held.push_back(b);
      io.write_behind(cid(x), std::move(b));
    }
    EXPECT_EQ(blocks.heap_blocks(), 4u);  // six blocks, room for two: the writes did not wait for room
    for (int x = 0; x < 6; ++x)           // queued or on disk: the content handed over either way
      EXPECT_TRUE(test::same_bits(as_block(*io.take(cid(x))), written[size_t(x)])) << "chunk " << x;
    io.drain();
  }
  for (int x = 0; x < 6; ++x)
    EXPECT_TRUE(test::same_bits(store.load(cid(x)), written[size_t(x)])) << "chunk " << x;
  held.clear();
  EXPECT_EQ(blocks.used_bytes(), 0u);
}

// Several writer threads: a chunk evicted again while its earlier content is still being written
// must end on disk with the newer content. A large first content and a small second one, handed
// over once the first write has begun: were the two writes allowed to overlap, the small one would
// finish first and the large one's later commit would leave the stale content as the chunk's file.
TEST(IoWorker, WithSeveralWritersTheLastContentHandedOverIsTheOneOnDisk) {
  test::TempDir dir;
  ChunkStore store(dir.path(), exact());
  constexpr size_t kLarge = 40'000, kSmall = 20;
  constexpr int kChunks = 6;
  HostBlockPool blocks(0);  // every block from the heap: this test is about order, not memory
  std::vector<GaussianBlock> last;
  {
    IoWorker io(store, blocks, true, 0, 100 * kLarge, 4);
    const auto hand_over = [&](int x, size_t count, uint64_t seed) {
      GaussianBlock g = test::random_block(count, seed);
      std::shared_ptr<HostBlock> b = blocks.make(count, 3);
      copy_gaussians(block_arrays(g), 0, count, b->arrays());
      io.write_behind(cid(x), std::move(b));
      return g;
    };
    for (int x = 0; x < kChunks; ++x) {
      hand_over(x, kLarge, uint64_t(x) + 100);
      // A writer takes it from the queue at once (a second hand-over still queued would replace it),
      // and writing its ~10 MB takes far longer than this.
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      last.push_back(hand_over(x, kSmall, uint64_t(x) + 200));
      EXPECT_TRUE(test::same_bits(as_block(*io.take(cid(x))), last.back())) << "chunk " << x;
    }
    io.drain();
  }
  for (int x = 0; x < kChunks; ++x) EXPECT_TRUE(test::same_bits(store.load(cid(x)), last[size_t(x)])) << "chunk " << x;
}

// Many chunks written and rewritten on four threads against a small queue: every chunk reads back
// as its last content, during the writes (from the queue or the disk) and after them.
TEST(IoWorker, SeveralWritersUnderBackPressureKeepEveryChunksLastContent) {
  test::TempDir dir;
  ChunkStore store(dir.path(), exact());
  constexpr size_t kCount = 200;
  constexpr int kChunks = 12, kRounds = 5;
  HostBlockPool blocks(4 * HostBlockPool::block_bytes(kCount));
  std::vector<GaussianBlock> last(kChunks);
  {
    IoWorker io(store, blocks, true, 0, 3 * kCount, 4);
    for (int r = 0; r < kRounds; ++r)
      for (int x = 0; x < kChunks; ++x) {
        const size_t count = kCount - size_t((x * 7 + r * 13) % 50);
        last[size_t(x)] = test::random_block(count, uint64_t(r * 100 + x) + 1);
        std::shared_ptr<HostBlock> b = blocks.make(count, 3);
        copy_gaussians(block_arrays(last[size_t(x)]), 0, count, b->arrays());
        io.write_behind(cid(x), std::move(b));
        const int y = (x * 5 + r) % kChunks;  // some chunk handed over earlier, or never yet
        if (r > 0 || y <= x) {
          EXPECT_TRUE(test::same_bits(as_block(*io.take(cid(y))), last[size_t(y)])) << "round " << r << " chunk " << y;
        }
      }
    io.drain();
    EXPECT_EQ(io.queued_write_gaussians(), 0u);
  }
  for (int x = 0; x < kChunks; ++x) EXPECT_TRUE(test::same_bits(store.load(cid(x)), last[size_t(x)])) << "chunk " << x;
  EXPECT_EQ(blocks.used_bytes(), 0u);
}

// A hand-over that finds the queue over its limit waits for the disk, and that wait is counted apart
// (IoStats::write_waits, write_wait_ms) as well as in the caller's waits.
TEST(IoWorker, AWaitForAFullWriteQueueIsCountedApart) {
  test::TempDir dir;
  ChunkStore store(dir.path(), exact());
  constexpr size_t kLarge = 40'000;  // ~30 MB: its write takes far longer than the next hand-over
  HostBlockPool blocks(0);
  {
    IoWorker io(store, blocks, true, 0, 1);
    store.counters().reset();
    std::vector<std::shared_ptr<HostBlock>> made;  // both ready first: handed over back to back
    for (int x = 0; x < 2; ++x) {
      made.push_back(blocks.make(kLarge, 3));
      copy_gaussians(block_arrays(test::random_block(kLarge, uint64_t(x) + 9)), 0, kLarge, made.back()->arrays());
    }
    for (int x = 0; x < 2; ++x) io.write_behind(cid(x), std::move(made[size_t(x)]));
    io.drain();
  }
  const IoStats s = store.counters().snapshot();
  EXPECT_EQ(s.write_waits, 1u);
  EXPECT_EQ(s.waits, 1u);
  EXPECT_GT(s.write_wait_ms, 0.0);
  EXPECT_LE(s.write_wait_ms, s.wait_ms);
  EXPECT_NE(s.summary().find("1 for a full write queue"), std::string::npos) << s.summary();
}

// Several chunks under one lock: each comes from where take() would get it (a queued write, the
// read-ahead, or the disk on the caller's thread), exactly as stored, in the order asked.
TEST(IoWorker, TakingSeveralAtOnceGivesEachFromWhereItIs) {
  test::TempDir dir;
  ChunkStore store(dir.path(), exact());
  for (int x = 0; x < 3; ++x) store.save(cid(x), test::random_block(40 + size_t(x), uint64_t(x) + 1));
  HostBlockPool blocks(16 * HostBlockPool::block_bytes(64));
  IoWorker io(store, blocks, true, 1000, 1000);
  io.prefetch({{cid(1), 41}});
  wait_for([&] { return io.staged_gaussians() == 41; });
  ASSERT_EQ(io.staged_gaussians(), 41u);
  // A newer content of chunk 2 queued for writing: it is what must come back, not the file.
  const GaussianBlock newer = test::random_block(42, 99);
  std::shared_ptr<HostBlock> queued = blocks.make(42, newer.sh_degree);
  copy_gaussians(block_arrays(newer), 0, 42, queued->arrays());
  io.write_behind(cid(2), queued);
  const std::vector<ChunkId> ids = {cid(2), cid(0), cid(1)};
  std::vector<IoWorker::Source> sources;
  const std::vector<IoWorker::Block> got = io.take_many(ids, sources);
  ASSERT_EQ(got.size(), 3u);
  // The queued write may have finished meanwhile: then the file holds the newer content.
  EXPECT_TRUE(sources[0] == IoWorker::Source::WriteBehind || sources[0] == IoWorker::Source::Disk);
  EXPECT_EQ(sources[1], IoWorker::Source::Disk);
  EXPECT_EQ(sources[2], IoWorker::Source::Prefetched);
  EXPECT_TRUE(test::same_bits(as_block(*got[0]), newer));
  EXPECT_TRUE(test::same_bits(as_block(*got[1]), store.load(cid(0))));
  EXPECT_TRUE(test::same_bits(as_block(*got[2]), store.load(cid(1))));
  EXPECT_EQ(io.staged_gaussians(), 0u);
  io.drain();
}
