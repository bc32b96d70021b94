// A keyframe's dense stereo at KITTI's full resolution (1241 x 376), the bulk of a keyframe load under
// real-time pacing with stereo input: the pair read from disk, SGBM, the left-right check and the
// confidence map. Needs ../shared/data/kitti_seq1 beside the checkout (or CHUNGS_KITTI=path).
//
//   bench_stereo_depth --benchmark_out=stereo.json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

#include "chungs/datasets/dataset.hpp"
#include "chungs/depth/stereo_depth.hpp"

using namespace chungs;

namespace {

std::unique_ptr<Dataset> kitti() {
  const char* env = std::getenv("CHUNGS_KITTI");
  const std::filesystem::path p = env ? env : "../shared/data/kitti_seq1";
  if (!std::filesystem::exists(p)) return nullptr;
  return open_dataset("kitti:" + p.string());
}

void BM_ReadPair(benchmark::State& state) {
  auto d = kitti();
  if (!d) return state.SkipWithError("no KITTI excerpt (set CHUNGS_KITTI)");
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(d->frame(i++ % d->size()));
}

void BM_StereoDepth(benchmark::State& state) {
  auto d = kitti();
  if (!d) return state.SkipWithError("no KITTI excerpt (set CHUNGS_KITTI)");
  const Frame f = d->frame(10);
  for (auto _ : state) {
    const StereoDepth s = stereo_depth(f.left, *f.right, f.camera.fx, f.baseline);
    benchmark::DoNotOptimize(s.valid);
  }
}

}  // namespace

BENCHMARK(BM_ReadPair)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StereoDepth)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
