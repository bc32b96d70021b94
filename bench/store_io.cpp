// Chunk I/O: save and load time of one chunk of 10 k Gaussians with Adam state (the paper
// reports 2.0 ms save / 2.8 ms load on NVMe), raw and zstd, with and without flushes, from the
// page cache and from the disk; and a streaming run of Residency that measures how often the
// optimiser still waits on the disk with and without the background prefetch, and the refinement's
// visits to groups of chunks under a budget with one or four writer threads.
//
//   bench_store_io --benchmark_out=store_io.json
// Files go to $CHUNGS_BENCH_DIR (default: the system temp folder), removed afterwards.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <random>
#include <thread>

#include "chungs/common/log.hpp"
#include "chungs/residency/residency.hpp"
#include "chungs/store/chunk_file.hpp"
#include "chungs/store/chunk_file_name.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

constexpr size_t kChunkGaussians = 10'000;
const ChunkId kId = chunk_id({12, 0, -3});

struct BenchDir {
  fs::path path;
  BenchDir() {
    const char* env = std::getenv("CHUNGS_BENCH_DIR");
    path = fs::path(env ? env : fs::temp_directory_path().string()) /
           ("chungs_bench_store_" + std::to_string(::getpid()));
    fs::create_directories(path);
  }
  ~BenchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};
const fs::path& bench_dir() {
  static BenchDir d;
  return d.path;
}

// "trained": every parameter and moment populated (what an evicted, optimised chunk holds);
// otherwise "fresh": new Gaussians with only DC colour and no optimiser history.
GaussianBlock make_block(size_t n, bool trained, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> g(0.f, 1.f);
  std::uniform_real_distribution<float> u(-5.f, 5.f);
  GaussianBlock b;
  b.resize(n);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) b.params.mean[3 * i + k] = 120.f + u(rng);
    for (int k = 0; k < 3; ++k) b.params.log_scale[3 * i + k] = -3.f + 0.7f * g(rng);
    for (int k = 0; k < 4; ++k) b.params.rotation[4 * i + k] = g(rng);
    b.params.opacity[i] = g(rng);
    for (int k = 0; k < kShFloats; ++k)
      b.params.sh[kShFloats * i + k] = k < 3 ? g(rng) : (trained ? 0.05f * g(rng) : 0.f);
    b.created_by_keyframe[i] = uint32_t(i / 700);
    b.created_at_step[i] = uint32_t(1000 + i / 50);
    if (!trained) continue;
    b.adam_steps[i] = uint32_t(1 + rng() % 300);
    b.lr_position_factor[i] = std::pow(0.998f, float(rng() % 300));
  }
  if (!trained) return b;
  for (GaussianParams* p : {&b.adam_m, &b.adam_v}) {
    const bool first = p == &b.adam_m;
    for (auto* v : {&p->mean, &p->log_scale, &p->rotation, &p->opacity, &p->sh})
      for (float& x : *v) x = first ? 1e-3f * g(rng) : 1e-7f * std::abs(g(rng));
  }
  return b;
}

void drop_from_page_cache(const fs::path& f) {
  const int fd = ::open(f.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fdatasync(fd);
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  ::close(fd);
}

void BM_ChunkSave(benchmark::State& st) {
  const bool compress = st.range(0), durable = st.range(1), trained = st.range(2);
  const int half = int(st.range(3));  // 1: Adam moments as binary16, 2: and SH rest
  const GaussianBlock b = make_block(kChunkGaussians, trained, 1);
  const fs::path f = bench_dir() / "save.chunk";
  const ChunkWriteOptions opt{compress, 1, true, durable, half >= 1, half >= 2};
  uint64_t bytes = 0;
  for (auto _ : st) bytes = write_chunk_file(f, kId, b, opt).file_bytes;
  st.counters["file_MB"] = double(bytes) / 1e6;
  st.counters["bytes_per_gaussian"] = double(bytes) / double(kChunkGaussians);
  st.SetBytesProcessed(int64_t(st.iterations() * kChunkGaussians * kChunkBytesPerGaussian));
}

void BM_ChunkLoad(benchmark::State& st) {
  const bool compress = st.range(0), cold = st.range(1), trained = st.range(2);
  const int half = int(st.range(3));
  const GaussianBlock b = make_block(kChunkGaussians, trained, 2);
  const fs::path f = bench_dir() / "load.chunk";
  const uint64_t bytes = write_chunk_file(f, kId, b, {compress, 1, true, true, half >= 1, half >= 2}).file_bytes;
  GaussianBlock out;
  for (auto _ : st) {
    if (cold) {
      st.PauseTiming();
      drop_from_page_cache(f);
      st.ResumeTiming();
    }
    read_chunk_file(f, out);
    benchmark::DoNotOptimize(out.params.opacity.data());
  }
  if (out.size() != kChunkGaussians) st.SkipWithError("chunk read back with the wrong size");
  st.counters["file_MB"] = double(bytes) / 1e6;
  st.SetBytesProcessed(int64_t(st.iterations() * kChunkGaussians * kChunkBytesPerGaussian));
}

// A checkpoint: `chunks` chunks of `gaussians` each are saved, then the map is made durable.
// mode 0, the former way: every save flushed (fdatasync of the file, fsync of the folder) and the
// manifest written durably; mode 1, ChunkStore: saves unflushed, one barrier in commit(); mode 2:
// as 1 with half-precision moments and SH rest. Time per chunk, barrier included.
void BM_Checkpoint(benchmark::State& st) {
  const size_t n = size_t(st.range(0));
  const int chunks = int(st.range(1));
  const bool store_mode = st.range(2) >= 1;
  std::vector<GaussianBlock> blocks;
  for (int k = 0; k < chunks; ++k) blocks.push_back(make_block(n, true, uint64_t(k + 7)));
  const fs::path dir = bench_dir() / ("ckpt_" + std::to_string(n) + "_" + std::to_string(chunks) + "_" +
                                      std::to_string(store_mode));
  log::set_level(log::Level::Warn);
  std::unique_ptr<ChunkStore> store;
  if (store_mode) {
    ChunkStoreConfig cfg;
    cfg.half_moments = cfg.half_sh_rest = st.range(2) == 2;
    store = std::make_unique<ChunkStore>(dir, cfg);
  }
  fs::create_directories(dir / "chunks");
  double barrier_ms = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : st) {
    if (store_mode) {
      for (int k = 0; k < chunks; ++k) store->save(chunk_id({k, 0, 0}), blocks[size_t(k)]);
      const double before = store->counters().snapshot().barrier_ms;
      store->commit();
      barrier_ms += store->counters().snapshot().barrier_ms - before;
    } else {
      Manifest m;
      for (int k = 0; k < chunks; ++k) {
        const ChunkId id = chunk_id({k, 0, 0});
        const auto info = write_chunk_file(dir / "chunks" / chunk_file_name(id, 0, false), id, blocks[size_t(k)],
                                           {false, 1, true, true});
        m.chunks[id] = {info.count, info.file_bytes, info.payload_checksum, 0};
      }
      m.write(dir / "manifest.txt", true);
    }
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  st.counters["ms_per_chunk"] = ms / (double(chunks) * double(st.iterations()));
  st.counters["barrier_ms"] = barrier_ms / double(st.iterations());
  st.SetBytesProcessed(int64_t(st.iterations() * chunks * n * kChunkBytesPerGaussian));
}

// A mapper checkpoint: 48 resident chunks of 10 k Gaussians (480 k, 348 MB at full precision),
// all modified, are written by Residency::flush() and committed; `threads` writer threads (1: the
// I/O thread alone), `half` = half_moments + half_sh_rest. Time of the flush (the caller waits).
void BM_Flush(benchmark::State& st) {
  const int threads = int(st.range(0));
  const bool half = st.range(1);
  constexpr int kResident = 48;
  constexpr size_t kPer = 10'000;
  const fs::path dir = bench_dir() / ("flush_" + std::to_string(threads) + std::to_string(half));
  log::set_level(log::Level::Warn);
  fs::remove_all(dir);
  ChunkStoreConfig sc;
  sc.half_moments = sc.half_sh_rest = half;
  ChunkStore store(dir, sc);
  CpuGaussianPool pool(kResident * kPer);
  ResidencyConfig rc;
  rc.budget_gaussians = kResident * kPer;
  rc.flush_threads = threads;
  Residency res(store, pool, rc);
  std::vector<ChunkId> ids;
  for (int x = 0; x < kResident; ++x) {
    ids.push_back(chunk_id({x, 0, 0}));
    if (!res.add(ids.back(), make_block(kPer, true, uint64_t(x))).ok) st.SkipWithError("add failed");
  }
  res.flush();
  store.counters().reset();
  for (auto _ : st) {
    st.PauseTiming();
    res.mark_dirty(ids);
    st.ResumeTiming();
    res.flush();
  }
  const IoStats s = store.counters().snapshot();
  st.counters["MB_per_flush"] = double(s.bytes_written) / 1e6 / double(st.iterations());
  st.counters["barrier_ms"] = s.barrier_ms / double(st.iterations());
  st.counters["GB_per_s"] = benchmark::Counter(double(s.bytes_written) / 1e9, benchmark::Counter::kIsRate);
}

// A camera drives along a corridor of 160 chunks of 2 k Gaussians; each step pins the 7 chunks
// around it (14 k Gaussians) under a budget of 20 k, "optimises" for 4 ms (the time the GPU
// would take; I/O can overlap it), marks them modified and moves half a chunk on. Counters:
// share of chunk loads the optimiser waited for, wait per step, evictions written behind.
void BM_ResidencyStream(benchmark::State& st) {
  const bool async = st.range(0), prefetch = st.range(1);
  constexpr int kChunks = 160, kHalfWidth = 3, kSteps = 2 * (kChunks - 2 * kHalfWidth - 2);
  constexpr size_t kPer = 2000;
  const fs::path dir = bench_dir() / ("stream_" + std::to_string(async) + std::to_string(prefetch));
  log::set_level(log::Level::Warn);
  IoStats stats;
  double wall_ms = 0;
  for (auto _ : st) {
    st.PauseTiming();
    fs::remove_all(dir);
    {
      ChunkStore store(dir);
      for (int x = 0; x < kChunks; ++x) store.save(chunk_id({x, 0, 0}), make_block(kPer, true, uint64_t(x)));
    }
    ChunkStore store(dir);
    store.counters().reset();
    CpuGaussianPool pool(20'000);
    ResidencyConfig rc;
    rc.budget_gaussians = 20'000;
    rc.async_io = async;
    Residency res(store, pool, rc);
    auto around = [&](int step) {
      std::vector<ChunkId> ids;
      const int centre = kHalfWidth + step / 2;
      for (int x = centre - kHalfWidth; x <= centre + kHalfWidth; ++x) ids.push_back(chunk_id({x, 0, 0}));
      return ids;
    };
    st.ResumeTiming();
    const auto t0 = std::chrono::steady_clock::now();
    for (int step = 0; step < kSteps; ++step) {
      const auto ids = around(step);
      if (!res.pin(ids).ok) st.SkipWithError("pinned set over budget");
      if (prefetch) {
        const auto next = around(step + 2);
        res.prefetch(next);
      }
      std::vector<uint32_t> slots;
      res.append_slots(ids, slots);
      for (uint32_t s : slots) pool.params().opacity[s] += 1e-3f;
      std::this_thread::sleep_for(std::chrono::milliseconds(4));
      res.mark_dirty(ids);
      res.unpin(ids);
    }
    res.flush();
    wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats = res.stats();
  }
  st.counters["steps"] = kSteps;
  st.counters["wall_ms_per_step"] = wall_ms / kSteps;
  st.counters["pool_loads"] = double(stats.pool_loads);
  st.counters["waited_pct"] = 100.0 * stats.wait_fraction();
  st.counters["wait_ms_per_step"] = stats.wait_ms / kSteps;
  st.counters["load_ms_avg"] = stats.mean_load_ms();
  st.counters["save_ms_avg"] = stats.mean_save_ms();
  st.counters["dirty_evictions"] = double(stats.evictions_dirty);
  st.counters["checkpoint_ms"] = stats.checkpoint_ms;
  st.counters["barrier_ms"] = stats.barrier_ms;
}


// The refinement's I/O pattern (Mapper::refine) under a budget: 8 groups of 240 chunks of 250
// Gaussians in a row, each group 0.8 of the budget (75 k); a step pins a view of 100 consecutive
// chunks of its group, reads its own and the next 4 steps' chunks ahead (as Mapper::refine does),
// "optimises" for 4 ms (a quarter of the GPU's step on a view 4x this size), and marks them modified;
// each group gets 40 steps, in `rounds` visits of 40 / rounds steps (mapper.refinement_rounds).
// `writers`: residency.write_behind_threads. Counters: the optimiser's wait in all, as a share of the
// time and for a full write queue, loads it waited for, saves and evictions written behind, and its own time
// making chunks resident (`loading_ms`, of which `take_ms` taking them from the I/O threads) and evicting.
void BM_RefinementVisits(benchmark::State& st) {
  const int writers = int(st.range(0)), rounds = int(st.range(1));
  constexpr int kGroups = 8, kGroupChunks = 240, kView = 100, kStepsPerGroup = 40, kReadAhead = 4;
  constexpr size_t kPer = 250, kBudget = 75'000;
  const fs::path dir = bench_dir() / "refinement_visits";
  log::set_level(log::Level::Warn);
  // The steps: (first chunk of the view) in visit order, views drawn at random within their group.
  std::mt19937 rng(7);
  std::vector<int> steps;
  for (int r = 0; r < rounds; ++r)
    for (int g = 0; g < kGroups; ++g) {
      const int n = kStepsPerGroup * (r + 1) / rounds - kStepsPerGroup * r / rounds;
      for (int i = 0; i < n; ++i)
        steps.push_back(g * kGroupChunks + std::uniform_int_distribution<int>(0, kGroupChunks - kView)(rng));
    }
  const auto view = [&](size_t i, std::vector<ChunkId>& out) {
    for (int x = steps[i]; x < steps[i] + kView; ++x) out.push_back(chunk_id({x, 0, 0}));
  };
  IoStats stats;
  double wall_ms = 0, final_ms = 0;
  for (auto _ : st) {
    st.PauseTiming();
    fs::remove_all(dir);
    {
      ChunkStore store(dir);
      for (int x = 0; x < kGroups * kGroupChunks; ++x) store.save(chunk_id({x, 0, 0}), make_block(kPer, true, uint64_t(x)));
    }
    ChunkStore store(dir);
    store.counters().reset();
    CpuGaussianPool pool(kBudget);
    ResidencyConfig rc;
    rc.budget_gaussians = kBudget;
    rc.write_behind_threads = writers;
    Residency res(store, pool, rc);
    st.ResumeTiming();
    const auto t0 = std::chrono::steady_clock::now();
    for (size_t i = 0; i < steps.size(); ++i) {
      std::vector<ChunkId> ids;
      view(i, ids);
      std::vector<ChunkId> next = ids;  // this step's chunks first, as Mapper::refine hints them
      for (size_t j = i + 1; j < std::min(steps.size(), i + 1 + kReadAhead); ++j) view(j, next);
      res.prefetch(next);
      if (!res.pin(ids).ok) st.SkipWithError("pinned set over budget");
      std::vector<uint32_t> slots;
      res.append_slots(ids, slots);
      for (uint32_t s : slots) pool.params().opacity[s] += 1e-3f;
      std::this_thread::sleep_for(std::chrono::milliseconds(4));
      res.mark_dirty(ids);
      res.unpin(ids);
    }
    wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats = res.stats();
    // What the run's final checkpoint would wait for: every modified chunk on disk, and the barrier
    // (the files written behind that never started their way to the disk are flushed here).
    const auto t1 = std::chrono::steady_clock::now();
    res.flush();
    store.commit();
    final_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  }
  st.counters["steps"] = double(steps.size());
  st.counters["wall_ms_per_step"] = wall_ms / double(steps.size());
  st.counters["wait_ms"] = stats.wait_ms;
  st.counters["wait_pct"] = 100.0 * stats.wait_ms / wall_ms;
  st.counters["final_checkpoint_ms"] = final_ms;
  st.counters["sync_loads"] = double(stats.sync_loads);
  st.counters["pool_loads"] = double(stats.pool_loads);
  st.counters["saves"] = double(stats.saves);
  st.counters["dirty_evictions"] = double(stats.evictions_dirty);
  st.counters["write_wait_ms"] = stats.write_wait_ms;
  // The optimiser thread's own time making chunks resident, and of it taking them from the I/O threads.
  st.counters["loading_ms"] = stats.loading_ms;
  st.counters["take_ms"] = stats.take_ms;
  st.counters["evicting_ms"] = stats.evicting_ms;
  st.counters["load_ms_avg"] = stats.mean_load_ms();
  st.counters["save_ms_avg"] = stats.mean_save_ms();
}
}  // namespace

BENCHMARK(BM_ChunkSave)
    ->ArgNames({"zstd", "durable", "trained", "half"})
    ->Args({0, 1, 1, 0})->Args({0, 0, 1, 0})->Args({1, 1, 1, 0})->Args({1, 0, 1, 0})->Args({1, 1, 0, 0})
    ->Args({0, 0, 1, 1})->Args({0, 0, 1, 2})->Args({1, 0, 1, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_ChunkLoad)
    ->ArgNames({"zstd", "cold", "trained", "half"})
    ->Args({0, 0, 1, 0})->Args({0, 1, 1, 0})->Args({1, 0, 1, 0})->Args({1, 1, 1, 0})->Args({1, 1, 0, 0})
    ->Args({0, 0, 1, 2})->Args({0, 1, 1, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Checkpoint)
    ->ArgNames({"gaussians", "chunks", "store"})
    ->Args({2000, 1, 0})->Args({2000, 1, 1})->Args({2000, 16, 0})->Args({2000, 16, 1})
    ->Args({2000, 16, 2})->Args({10000, 16, 0})->Args({10000, 16, 1})->Args({10000, 16, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_Flush)
    ->ArgNames({"threads", "half"})
    ->Args({1, 0})->Args({4, 0})->Args({8, 0})->Args({1, 1})->Args({4, 1})->Args({8, 1})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_ResidencyStream)
    ->ArgNames({"async", "prefetch"})
    ->Args({0, 0})->Args({1, 0})->Args({1, 1})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

BENCHMARK(BM_RefinementVisits)
    ->ArgNames({"writers", "rounds"})
    ->Args({1, 1})->Args({4, 1})->Args({1, 8})->Args({4, 8})->Args({1, 16})->Args({4, 16})->Args({16, 16})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

BENCHMARK_MAIN();
