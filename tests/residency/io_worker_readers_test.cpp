// Chunks are read ahead on every I/O thread: with one reading thread, a refinement step that loads
// ~60 chunks left most of them to the optimiser's own reads (GPU, 2 km street under 300 k,
// bench/README.md, issue 19). Here one read is held and the next chunk must arrive meanwhile.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "chungs/residency/io_worker.hpp"
#include "chungs/store/atomic_file.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
std::atomic<bool> claimed{false}, holding{false}, release{false};
std::atomic<int> reads{0};
std::filesystem::path held;  // written before `holding` is set

// Holds the first chunk file opened for reading until released (10 s at most, so that a failure
// cannot hang the suite).
void hold_first_read(const std::filesystem::path& file, FileEvent e) {
  if (e != FileEvent::Reading || file.extension() != ".chunk") return;
  reads++;
  if (claimed.exchange(true)) return;
  held = file;
  holding = true;
  for (int i = 0; i < 1000 && !release; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
}

template <typename F>
void wait_for(F done) {
  for (int i = 0; i < 600 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}
}  // namespace

TEST(IoWorkerReaders, AChunkIsReadAheadWhileAnotherReadIsHeld) {
  test::TempDir dir;
  ChunkStoreConfig c;
  c.durable = false;
  ChunkStore store(dir.path(), c);
  const ChunkId a = chunk_id({1, 0, 0}), b = chunk_id({2, 0, 0});
  store.save(a, test::random_block(30, 1));
  store.save(b, test::random_block(40, 2));
  ASSERT_EQ(store.chunk_path(a).extension(), ".chunk") << "the hook picks chunk files by their extension";
  HostBlockPool blocks(16 * HostBlockPool::block_bytes(64));
  claimed = holding = release = false;
  reads = 0;
  set_file_event_hook(hold_first_read);
  {
    IoWorker io(store, blocks, true, 1000, 1000, 2);
    io.prefetch({{a, 30}, {b, 40}});
    wait_for([&] { return holding.load(); });
    EXPECT_TRUE(holding) << "nothing was read ahead";
    // Either thread may take either chunk first: the other one must arrive while that read is held.
    const size_t other = held == store.chunk_path(a) ? 40 : 30;
    wait_for([&] { return io.staged_gaussians() == other; });
    const size_t staged_while_held = io.staged_gaussians();
    release = true;
    wait_for([&] { return io.staged_gaussians() == 70; });
    set_file_event_hook(nullptr);
    EXPECT_EQ(staged_while_held, other) << "the second chunk waited for the first one's read";
    EXPECT_EQ(io.staged_gaussians(), 70u);
    EXPECT_EQ(reads.load(), 2);
    std::vector<IoWorker::Source> sources;
    const std::vector<ChunkId> ids = {a, b};
    const std::vector<IoWorker::Block> got = io.take_many(ids, sources);
    EXPECT_EQ(sources[0], IoWorker::Source::Prefetched);
    EXPECT_EQ(sources[1], IoWorker::Source::Prefetched);
    EXPECT_EQ(got[0]->size(), 30u);
    EXPECT_EQ(got[1]->size(), 40u);
  }
  set_file_event_hook(nullptr);
}
