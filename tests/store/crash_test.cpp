// Kill-at-any-moment test: a child process rewrites chunks and the manifest in a loop and is
// killed with SIGKILL at random moments. After each kill the map folder must reopen with every
// chunk at the version last reported written or the one being written, bit-exact and with valid
// checksums, and with a manifest that parses and matches the files.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <random>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/store/chunk_store.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
constexpr int kChunks = 6;

ChunkId id_of(int k) { return chunk_id({k - 3, 2 * k, -k}); }
bool is_removal(uint32_t v) { return v > 0 && v % 10 == 9; }

// Version v of chunk k; every Gaussian carries v in created_at_step so a file tells its version.
GaussianBlock version_block(int k, uint32_t v) {
  GaussianBlock b = test::random_block(1 + (k * 7 + v * 13) % 40, uint64_t(k) << 32 | v);
  for (auto& s : b.created_at_step) s = v;
  return b;
}

struct Record {
  uint32_t chunk, version;
};

[[noreturn]] void child_loop(const fs::path& dir, std::array<uint32_t, kChunks> version, bool durable,
                             int write_fd, uint32_t seed) {
  try {
    ChunkStoreConfig cfg;
    cfg.half_moments = cfg.half_sh_rest = false;  // these tests compare exact round trips
    cfg.durable = durable;
    cfg.compress = seed % 3 == 0;
    ChunkStore store(dir, cfg);
    std::mt19937 rng(seed);
    for (;;) {
      const int k = int(rng() % kChunks);
      const uint32_t v = ++version[k];
      if (is_removal(v))
        store.remove(id_of(k));
      else
        store.save(id_of(k), version_block(k, v));
      const Record r{uint32_t(k), v};
      if (::write(write_fd, &r, sizeof r) != sizeof r) ::_exit(4);
      if (rng() % 3 == 0) store.commit();
    }
  } catch (...) {
    ::_exit(3);
  }
}
}  // namespace

TEST(ChunkStoreCrash, EveryChunkIsOldOrNewAfterSigkillAtRandomMoments) {
  test::TempDir dir;
  std::array<uint32_t, kChunks> done{};  // last version each chunk is known to have on disk
  std::mt19937 rng(2024);
  const int trials = 300;
  size_t writes = 0, caught_mid_write = 0;
  for (int trial = 0; trial < trials; ++trial) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const bool durable = trial % 2 == 0;
    const uint32_t seed = uint32_t(rng());
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(fds[0]);
      child_loop(dir.path(), done, durable, fds[1], seed);
    }
    ::close(fds[1]);
    Record r;
    const auto take = [&] {
      ASSERT_LT(r.chunk, uint32_t(kChunks));
      ASSERT_EQ(r.version, done[r.chunk] + 1) << "versions are written in order";
      done[r.chunk] = r.version;
      ++writes;
    };
    // Every other kill comes after the child's first write: under a loaded machine (ctest -j) a child
    // may otherwise spend the whole random wait starting up, and the test would kill only idle stores.
    if (trial % 4 >= 2 && ::read(fds[0], &r, sizeof r) == sizeof r) ASSERT_NO_FATAL_FAILURE(take());
    std::this_thread::sleep_for(std::chrono::microseconds(rng() % 12000));
    ::kill(pid, SIGKILL);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
        << "child failed on its own (exit " << WEXITSTATUS(status) << ") in trial " << trial;
    while (::read(fds[0], &r, sizeof r) == sizeof r) ASSERT_NO_FATAL_FAILURE(take());
    ::close(fds[0]);

    // Whatever the moment of the kill, the manifest on disk is whole (old or new).
    if (fs::exists(dir / "manifest.txt")) {
      ASSERT_NO_THROW(Manifest::read(dir / "manifest.txt"));
    }
    ChunkStoreConfig cfg;
    cfg.half_moments = cfg.half_sh_rest = false;  // these tests compare exact round trips
    cfg.durable = false;
    cfg.verify_on_open = true;  // every payload checksum
    ChunkStore store(dir.path(), cfg);
    for (int k = 0; k < kChunks; ++k) {
      const uint32_t old_v = done[k], new_v = done[k] + 1;
      uint32_t seen;
      if (store.contains(id_of(k))) {
        const GaussianBlock b = store.load(id_of(k));
        ASSERT_GT(b.size(), 0u);
        seen = b.created_at_step[0];
        ASSERT_TRUE(seen == old_v || seen == new_v) << "chunk " << k << " at version " << seen
                                                    << ", expected " << old_v << " or " << new_v;
        ASSERT_FALSE(is_removal(seen));
        ASSERT_TRUE(test::same_bits(b, version_block(k, seen))) << "chunk " << k << " torn in trial " << trial;
        ASSERT_EQ(store.count(id_of(k)), b.size());
      } else {
        seen = (old_v == 0 || is_removal(old_v)) ? old_v : new_v;
        ASSERT_TRUE(old_v == 0 || is_removal(old_v) || is_removal(new_v))
            << "chunk " << k << " vanished in trial " << trial;
      }
      if (seen != old_v) ++caught_mid_write;
      done[k] = seen;
    }
    // The reopened store committed a manifest matching the files.
    ASSERT_EQ(Manifest::read(dir / "manifest.txt").chunks, store.manifest().chunks);
  }
  // Half the kills wait for a first write, so fewer than that means the children did not write.
  EXPECT_GE(writes, size_t(trials / 2)) << "the children should have written chunks";
  std::printf("[ crash    ] %d kills, %zu chunk writes completed, %zu kills caught a write in flight\n",
              trials, writes, caught_mid_write);
}
