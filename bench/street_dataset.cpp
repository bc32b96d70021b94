// On-demand rendering of the synthetic street (synth-street dataset): stereo frames per second
// along the route, as a mapper reading the dataset would see them, at two image sizes; and with
// two threads asking at once (a prefetching reader).
//
//   bench_street_dataset --benchmark_out=street_dataset.json
#include <benchmark/benchmark.h>

#include <atomic>
#include <thread>

#include "chungs/common/log.hpp"
#include "chungs/synth/street_dataset.hpp"

using namespace chungs;

namespace {

void BM_StreetFrame(benchmark::State& st) {
  log::set_level(log::Level::Warn);
  synth::StreetDatasetOptions o;
  o.street.length_m = 10000;
  o.width = int(st.range(0));
  o.height = int(st.range(1));
  const int threads = int(st.range(2));
  const synth::StreetDataset ds(o);
  std::atomic<size_t> next{0};
  size_t frames = 0;
  for (auto _ : st) {
    // Consecutive frames, as a mapper asks for them; each thread takes the next one.
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t)
      pool.emplace_back([&] {
        const size_t i = next++ % ds.size();
        benchmark::DoNotOptimize(ds.frame(i).left.data());
      });
    for (auto& t : pool) t.join();
    frames += size_t(threads);
  }
  st.counters["frames_per_s"] = benchmark::Counter(double(frames), benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK(BM_StreetFrame)
    ->ArgNames({"width", "height", "threads"})
    ->Args({620, 188, 1})->Args({1241, 376, 1})->Args({620, 188, 2})->Args({1241, 376, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(10.0);

BENCHMARK_MAIN();
