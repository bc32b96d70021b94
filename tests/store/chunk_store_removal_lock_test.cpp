// A superseded chunk file is deleted outside the store's lock: an unlink can wait for the file's
// writeback, and under the lock every reader of the store (the optimiser's loads, the read-ahead)
// waited with it. On the GPU that was seconds of a refinement under a small budget, uncounted as
// I/O wait (bench/README.md, issue 19).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <thread>

#include "chungs/store/atomic_file.hpp"
#include "chungs/store/chunk_store.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
std::atomic<bool> removing{false}, release{false};

// Holds the first removal until released (at most 10 s, so that a failure cannot hang the suite).
void hold_removal(const std::filesystem::path&, FileEvent e) {
  if (e != FileEvent::Removing || removing.exchange(true)) return;
  for (int i = 0; i < 1000 && !release; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
}
}  // namespace

TEST(ChunkStoreRemoval, ReadersGoOnWhileASupersededFileIsDeleted) {
  test::TempDir dir;
  ChunkStoreConfig c;
  c.durable = false;
  ChunkStore store(dir.path(), c);
  const ChunkId a = chunk_id({1, 0, 0}), b = chunk_id({2, 0, 0});
  store.save(a, test::random_block(30, 1));
  store.save(b, test::random_block(40, 2));
  // Not committed: the next save of `a` deletes its first file at once.
  removing = false;
  release = false;
  set_file_event_hook(hold_removal);
  std::thread writer([&] { store.save(a, test::random_block(31, 3)); });
  for (int i = 0; i < 1000 && !removing; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(removing) << "the save did not delete the superseded file";
  auto reader = std::async(std::launch::async, [&] {
    const GaussianBlock got = store.load(b);
    return std::make_pair(store.contains(a), got.size());
  });
  const bool went_on = reader.wait_for(std::chrono::seconds(3)) == std::future_status::ready;
  release = true;
  writer.join();
  set_file_event_hook(nullptr);
  EXPECT_TRUE(went_on) << "a reader of the store waited for the deletion";
  const auto [has_a, b_size] = reader.get();
  EXPECT_TRUE(has_a);
  EXPECT_EQ(b_size, 40u);
  EXPECT_EQ(store.load(a).size(), 31u);
}
