// Host heap that threads writing and reading chunk files keep afterwards: the mapping run's chunk
// I/O threads (one per core) under its allocator settings (one arena, freed memory kept:
// common/heap.hpp), each writing and reading back chunks of one size in a folder of its own.
//
//   bench_io_thread_heap THREADS GAUSSIANS [ROUNDS [zstd]]
// prints the RSS growth over the writes and reads (the blocks themselves are made before) and the wall
// time a round of them takes (per thread; all threads at once). Files go to
// $CHUNGS_BENCH_DIR (default: the system temp folder), removed afterwards.
#include <malloc.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "chungs/common/heap.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/chunk_file.hpp"
#include "chungs/store/chunk_store.hpp"

using namespace chungs;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_io_thread_heap THREADS GAUSSIANS [ROUNDS [zstd]]\n");
    return 2;
  }
  const int threads = std::atoi(argv[1]), rounds = argc > 3 ? std::atoi(argv[3]) : 5;
  const long gaussians = std::atol(argv[2]);
  const bool zstd = argc > 4 && std::string(argv[4]) == "zstd";
  if (threads < 1 || threads > 256 || gaussians < 1 || gaussians > 1'000'000 || rounds < 1 ||
      (argc > 4 && !zstd) || argc > 5) {
    std::fprintf(stderr, "bench_io_thread_heap: THREADS in [1, 256], GAUSSIANS in [1, 1e6], ROUNDS >= 1, then "
                         "nothing or zstd\n");
    return 2;
  }
  mallopt(M_ARENA_MAX, 1);  // as the CLI (apps/diskchungs/allocator.cpp)
  keep_heap_for_reuse(0);
  const char* env = std::getenv("CHUNGS_BENCH_DIR");
  const fs::path dir = fs::path(env ? env : fs::temp_directory_path().string()) /
                       ("chungs_bench_io_heap_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const size_t n = static_cast<size_t>(threads);
  std::vector<GaussianBlock> blocks(n), back(n);
  std::mt19937 rng(1);
  std::normal_distribution<float> g(0.f, 1.f);
  for (int t = 0; t < threads; ++t) {
    GaussianBlock& b = blocks[size_t(t)];
    b.resize(size_t(gaussians));
    for (GaussianParams* p : {&b.params, &b.adam_m, &b.adam_v})
      for (auto* v : {&p->mean, &p->log_scale, &p->rotation, &p->opacity, &p->sh})
        for (float& x : *v) x = p == &b.adam_v ? 1e-6f * g(rng) * g(rng) : g(rng);
    back[size_t(t)].resize(size_t(gaussians));
  }
  const ChunkStoreConfig store;  // the store's encodings
  ChunkWriteOptions opt;
  opt.durable = false;
  opt.half_moments = store.half_moments;
  opt.half_sh_rest = store.half_sh_rest;
  opt.compress = zstd;  // the store's level and byte shuffle otherwise
  const double before = double(current_rss_bytes()) / 1048576.0;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      const fs::path f = dir / (std::to_string(t) + ".chunk");
      for (int r = 0; r < rounds; ++r) {
        write_chunk_file(f, ChunkId(0), blocks[size_t(t)], opt);
        read_chunk_file(open_for_reading(f), f, [&](uint64_t, int) { return block_arrays(back[size_t(t)]); });
      }
    });
  for (std::thread& th : pool) th.join();
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const double after = double(current_rss_bytes()) / 1048576.0;
  std::printf("%d threads, chunks of %ld Gaussians%s, %d rounds: RSS +%.1f MB (%.1f -> %.1f); %.2f ms a write and read\n",
              threads, gaussians, zstd ? " (zstd)" : "", rounds, after - before, before, after, ms / rounds);
  std::error_code ec;
  fs::remove_all(dir, ec);
  return 0;
}
