// Checkpoint writes on several threads: every chunk saved with its own content, and any failure
// (producing a block or saving it) comes back to the caller without a hang.
#include "chungs/residency/parallel_save.hpp"

#include <gtest/gtest.h>

#include <map>
#include <thread>

#include "chungs/common/error.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
ChunkStoreConfig kill_safe() {
  ChunkStoreConfig c;
  c.half_moments = c.half_sh_rest = false;  // these tests compare exact round trips
  c.durable = false;
  return c;
}
std::vector<ChunkId> ids_of(int n) {
  std::vector<ChunkId> ids;
  for (int k = 0; k < n; ++k) ids.push_back(chunk_id({k, -k, 1}));
  return ids;
}
}  // namespace

TEST(ParallelSave, EveryChunkGetsItsOwnBlockWhateverTheThreadCount) {
  for (int threads : {1, 2, 4, 7}) {
    test::TempDir dir;
    ChunkStore store(dir.path(), kill_safe());
    const auto ids = ids_of(23);
    std::vector<std::thread::id> producers;
    save_chunks_in_parallel(
        store, ids,
        [&](size_t k, GaussianBlock& b) {
          producers.push_back(std::this_thread::get_id());
          b = test::random_block(5 + k, k);
        },
        threads);
    for (const auto& p : producers)
      EXPECT_TRUE(p == std::this_thread::get_id()) << "blocks come from the caller";
    ASSERT_EQ(store.size(), ids.size());
    for (size_t k = 0; k < ids.size(); ++k)
      EXPECT_TRUE(test::same_bits(store.load(ids[k]), test::random_block(5 + k, k))) << k << ", " << threads;
  }
}

TEST(ParallelSave, AFailingProducerOrSaveReachesTheCaller) {
  test::TempDir dir;
  ChunkStore store(dir.path(), kill_safe());
  const auto ids = ids_of(40);
  EXPECT_THROW(save_chunks_in_parallel(
                   store, ids,
                   [&](size_t k, GaussianBlock& b) {
                     if (k == 17) fail("gather failed for chunk ", k);
                     b = test::random_block(3, k);
                   },
                   4),
               Error);
  EXPECT_THROW(save_chunks_in_parallel(
                   store, ids,
                   [&](size_t k, GaussianBlock& b) {
                     b = test::random_block(3, k);
                     if (k == 9) b.adam_steps.pop_back();  // inconsistent: the save refuses it
                   },
                   4),
               Error);
  // The store stays usable and consistent with its files.
  store.commit();
  ChunkStore* s = &store;
  for (ChunkId id : s->ids()) EXPECT_EQ(s->load(id).size(), 3u);
}
