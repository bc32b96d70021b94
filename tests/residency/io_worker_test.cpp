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
