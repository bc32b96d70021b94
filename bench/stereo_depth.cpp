// A keyframe's dense stereo at KITTI's full resolution (1241 x 376), the bulk of a keyframe load under
// real-time pacing with stereo input: the pair read from disk, SGBM, the left-right check and the
// confidence map; on the host (/0) and with the matching on the GPU (/1). Needs
// ../shared/data/kitti_seq1 beside the checkout (or CHUNGS_KITTI=path).
//
//   bench_stereo_depth --benchmark_out=stereo.json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

#include "chungs/common/error.hpp"
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

// range(0): 1 = semi-global matching on the GPU (the default of --device cuda runs).
void BM_StereoDepth(benchmark::State& state) {
  auto d = kitti();
  if (!d) return state.SkipWithError("no KITTI excerpt (set CHUNGS_KITTI)");
  StereoDepthConfig config;
  config.cuda = state.range(0) == 1;
#if !CHUNGS_WITH_CUDA
  if (config.cuda) return state.SkipWithError("built without CUDA");
#endif
  const Frame f = d->frame(10);
  try {
    for (auto _ : state) {
      const StereoDepth s = stereo_depth(f.left, *f.right, f.camera.fx, f.baseline, config);
      benchmark::DoNotOptimize(s.valid);
    }
  } catch (const Error& e) {  // no usable GPU
    state.SkipWithError(e.what());
  }
}

}  // namespace

BENCHMARK(BM_ReadPair)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StereoDepth)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
