// The sampler's draw of new Gaussians for one keyframe at KITTI's full resolution (1241 x 376): the
// host work each keyframe costs the optimiser thread after the acceptance map came back from the GPU
// (measured at ~31 ms a keyframe in `run --pacing anytime` on KITTI, report.json
// time.optimiser_ms.keyframe_sample). Acceptance ~3 % a pixel (~14 k draws, what KITTI keyframes
// give), depth 2-80 m with a tenth of it missing, a few hundred chunks of the map excluded.
//
//   bench_sampler --benchmark_out=sampler.json
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <unordered_set>

#include "chungs/mapping/sampler.hpp"

using namespace chungs;

namespace {

const Camera kKitti(1241, 376, 718.856, 718.856, 607.19, 185.22);

struct Inputs {
  ImageF image, depth, probability;
  std::unordered_set<ChunkId> exclude;
  Inputs() : image(kKitti.width, kKitti.height, 3), depth(kKitti.width, kKitti.height, 1),
             probability(kKitti.width, kKitti.height, 1) {
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> U(0, 1);
    for (float& v : image.vec()) v = U(rng);
    // A smooth scene (near at the bottom and sides, far at the centre), so that draws gather in chunks.
    for (int y = 0; y < depth.height(); ++y)
      for (int x = 0; x < depth.width(); ++x) {
        const float cx = std::abs(float(x) / float(depth.width()) - 0.5f) * 2, cy = float(y) / float(depth.height());
        depth(x, y) = U(rng) < 0.1f ? 0.f : 2.f + 78.f * (1 - cx) * (1 - cy);
      }
    for (float& v : probability.vec()) v = 0.06f * U(rng);
    for (int x = -20; x < 20; ++x)
      for (int z = -20; z < 0; ++z) exclude.insert(chunk_id({x, 0, z}));
  }
};

void BM_SampleKeyframe(benchmark::State& state) {
  static const Inputs in;
  SamplerConfig cfg;
  cfg.fill_depth = 80.0;
  std::mt19937_64 rng(1);
  uint64_t kept = 0;
  for (auto _ : state) {
    SampleStats st;
    auto batches = sample_gaussians(cfg, in.image, in.depth, in.probability, kKitti, SE3(), 10.0, 1, 0, rng, &st,
                                    &in.exclude, 0);
    benchmark::DoNotOptimize(batches);
    kept += st.kept;
  }
  state.counters["gaussians_per_keyframe"] = double(kept) / double(state.iterations());
}
BENCHMARK(BM_SampleKeyframe)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
