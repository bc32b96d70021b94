// Power loss, modelled: a child process saves, removes and commits chunks, then "loses power":
// every file made visible without a flush since (as the file event hook reports) is truncated to
// zero length or deleted, the worst a filesystem may do to unflushed data and names, and the
// child vanishes without closing the store. The folder must then reopen with every chunk valid and
// at its content of the last commit or a later one (deleting unflushed files: exactly the last
// commit). A store that renamed unflushed files over committed ones, or wrote the manifest before
// flushing the files it names, fails here.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <map>
#include <random>
#include <set>
#include <vector>

#include "chungs/store/chunk_store.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
constexpr int kChunks = 8;
ChunkId id_of(int k) { return chunk_id({k, 1 - k, 2}); }
GaussianBlock version_block(int k, uint32_t v) {
  GaussianBlock b = test::random_block(1 + (k * 5 + v * 11) % 30, uint64_t(k) << 32 | v);
  for (auto& s : b.created_at_step) s = v;
  return b;
}

std::map<std::string, FileEvent>* events = nullptr;
void record(const fs::path& file, FileEvent e) {
  // A read changes nothing on disk, and a started writeback makes nothing durable.
  if (e != FileEvent::Reading && e != FileEvent::WritebackStarted) (*events)[file.lexically_normal().string()] = e;
}

struct Op {
  int chunk;         // -1: commit
  uint32_t version;  // 0: remove
};

// The same plan in child and parent: a first commit, then saves, removals and maybe commits.
std::vector<Op> plan(uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<Op> ops;
  for (int k = 0; k < kChunks; ++k) ops.push_back({k, k % 2 ? 0u : 1u});  // whatever the folder held
  ops.push_back({-1, 0});
  const int n = 10 + int(rng() % 30);
  for (int i = 0; i < n; ++i) {
    const uint32_t r = rng() % 10;
    if (r == 0)
      ops.push_back({-1, 0});
    else
      ops.push_back({int(rng() % kChunks), r == 1 ? 0u : uint32_t(2 + i)});
  }
  return ops;
}

enum class Loss { Truncate, Delete, Mixed };

[[noreturn]] void child(const fs::path& dir, uint32_t seed, Loss loss) {
  try {
    std::map<std::string, FileEvent> seen;
    events = &seen;
    set_file_event_hook(record);
    ChunkStoreConfig exact;
    exact.half_moments = exact.half_sh_rest = false;  // the reader compares exact round trips
    auto* store = new ChunkStore(dir, exact);  // never destroyed: power goes before any close
    for (const Op& op : plan(seed)) {
      if (op.chunk < 0)
        store->commit();
      else if (op.version == 0)
        store->remove(id_of(op.chunk));
      else
        store->save(id_of(op.chunk), version_block(op.chunk, op.version));
    }
    set_file_event_hook(nullptr);
    std::mt19937 rng(seed ^ 0x5eed);
    for (const auto& [file, e] : seen) {
      if (e != FileEvent::Written || !fs::exists(file)) continue;
      const bool del = loss == Loss::Delete || (loss == Loss::Mixed && rng() % 2);
      if (del)
        fs::remove(file);
      else if (loss == Loss::Truncate || rng() % 2)
        fs::resize_file(file, 0);  // Mixed: the other half of the kept files survive whole
    }
    ::_exit(0);
  } catch (...) {
    ::_exit(3);
  }
}

void run_trial(const fs::path& dir, uint32_t seed, Loss loss) {
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) child(dir, seed, loss);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child failed, seed " << seed;

  // Per chunk: its version at the last commit and every version it took after it (0: absent).
  std::vector<uint32_t> committed(kChunks, 0), current(kChunks, 0);
  std::vector<std::set<uint32_t>> later(kChunks);
  for (const Op& op : plan(seed)) {
    if (op.chunk < 0) {
      committed = current;
      for (auto& s : later) s.clear();
    } else {
      current[op.chunk] = op.version;
      later[op.chunk].insert(op.version);
    }
  }
  ChunkStoreConfig cfg;
  cfg.half_moments = cfg.half_sh_rest = false;  // these tests compare exact round trips
  cfg.verify_on_open = true;
  std::unique_ptr<ChunkStore> store;
  ASSERT_NO_THROW(store = std::make_unique<ChunkStore>(dir, cfg)) << "seed " << seed;
  for (int k = 0; k < kChunks; ++k) {
    uint32_t v = 0;
    if (store->contains(id_of(k))) {
      const GaussianBlock b = store->load(id_of(k));
      ASSERT_GT(b.size(), 0u);
      v = b.created_at_step[0];
      ASSERT_TRUE(test::same_bits(b, version_block(k, v))) << "chunk " << k << " torn, seed " << seed;
    }
    if (loss == Loss::Delete) {
      EXPECT_EQ(v, committed[k]) << "chunk " << k << " not at the last commit, seed " << seed;
    } else {
      EXPECT_TRUE(v == committed[k] || later[k].count(v))
          << "chunk " << k << " at version " << v << ", committed " << committed[k] << ", seed " << seed;
    }
  }
}
}  // namespace

TEST(ChunkStorePowerLoss, UnflushedFilesDeletedLeaveExactlyTheLastCommit) {
  for (uint32_t seed = 1; seed <= 12; ++seed) {
    test::TempDir dir;
    run_trial(dir.path(), seed, Loss::Delete);
    if (HasFailure()) return;
  }
}

TEST(ChunkStorePowerLoss, UnflushedFilesTruncatedLeaveEveryChunkValid) {
  for (uint32_t seed = 100; seed < 112; ++seed) {
    test::TempDir dir;
    run_trial(dir.path(), seed, Loss::Truncate);
    if (HasFailure()) return;
  }
}

TEST(ChunkStorePowerLoss, RepeatedLossesOnOneFolderKeepEveryChunkValid) {
  test::TempDir dir;
  for (uint32_t seed = 200; seed < 215; ++seed) {
    run_trial(dir.path(), seed, Loss::Mixed);
    if (HasFailure()) return;
  }
}
