// A chunk written behind an eviction is left to the page cache until the next commit: it is often
// loaded, trained and evicted again first, and starting every version's way to the disk made the
// disk's write bandwidth the limit of a refinement under a small budget (bench/README.md, issue 19).
// A save made for a checkpoint still starts at once, so the commit's barrier has less left to do;
// the commit flushes both.
#include <gtest/gtest.h>

#include <mutex>
#include <set>
#include <string>

#include "chungs/residency/io_worker.hpp"
#include "chungs/store/atomic_file.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
std::mutex seen_mutex;
std::set<std::string> started, synced;

void record(const std::filesystem::path& file, FileEvent e) {
  if (file.extension() != ".chunk") return;
  std::lock_guard lock(seen_mutex);
  if (e == FileEvent::WritebackStarted) started.insert(file.filename().string());
  if (e == FileEvent::Synced) synced.insert(file.filename().string());
}

std::shared_ptr<const HostBlock> host_copy(HostBlockPool& blocks, const GaussianBlock& g) {
  std::shared_ptr<HostBlock> h = blocks.make(g.size(), g.sh_degree);
  copy_gaussians(block_arrays(g), 0, g.size(), h->arrays());
  return h;
}
}  // namespace

TEST(IoWorkerWriteback, AnEvictedChunkIsLeftToThePageCacheUntilTheCommitFlushesIt) {
  test::TempDir dir;
  ChunkStore store(dir.path());  // durable, as a run's
  HostBlockPool blocks(16 * HostBlockPool::block_bytes(64));
  const ChunkId evicted = chunk_id({1, 0, 0}), checkpointed = chunk_id({2, 0, 0});
  started.clear();
  synced.clear();
  set_file_event_hook(record);
  {
    IoWorker io(store, blocks, /*background=*/false, 1000, 1000);
    io.write_behind(evicted, host_copy(blocks, test::random_block(30, 1)));
  }
  store.save(checkpointed, test::random_block(40, 2));
  const std::string evicted_file = store.chunk_path(evicted).filename().string();
  const std::string checkpointed_file = store.chunk_path(checkpointed).filename().string();
  EXPECT_FALSE(started.count(evicted_file)) << "the evicted chunk's file was sent to the disk at once";
  EXPECT_TRUE(started.count(checkpointed_file)) << "a checkpoint's save no longer starts its writeback";
  store.commit();
  set_file_event_hook(nullptr);
  EXPECT_TRUE(synced.count(evicted_file)) << "the commit did not flush the evicted chunk";
  EXPECT_TRUE(synced.count(checkpointed_file));
  EXPECT_EQ(store.load(evicted).size(), 30u);
}
