// Time of one LPIPS pair on the CPU at KITTI's full and half resolution. The weights are random
// (the published ones cannot be fetched here): the cost depends on the shapes only.
#include <benchmark/benchmark.h>

#include <random>

#include "chungs/eval/lpips.hpp"

namespace {

chungs::LpipsWeights random_weights() {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-0.05f, 0.05f), head(0.f, 1.f);
  chungs::LpipsWeights w;
  for (size_t l = 0; l < chungs::kAlexConv.size(); ++l) {
    const auto& s = chungs::kAlexConv[l];
    w.conv[l].weight.resize(size_t(s.out) * s.in * s.kernel * s.kernel);
    for (float& v : w.conv[l].weight) v = u(rng);
    w.conv[l].bias.assign(size_t(s.out), 0.01f);
    w.lin[l].resize(size_t(s.out));
    for (float& v : w.lin[l]) v = head(rng);
  }
  return w;
}

chungs::ImageF pattern(int w, int h, float noise, std::mt19937& rng) {
  std::normal_distribution<float> n(0.f, noise);
  chungs::ImageF img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) img(x, y, c) = std::clamp(0.5f + 0.3f * std::sin(0.05f * x * (c + 1) + 0.07f * y) + n(rng), 0.f, 1.f);
  return img;
}

void BM_LpipsPair(benchmark::State& state) {
  const chungs::Lpips metric(random_weights());
  std::mt19937 rng(2);
  const int w = int(state.range(0)), h = int(state.range(1));
  const chungs::ImageF a = pattern(w, h, 0.f, rng), b = pattern(w, h, 0.05f, rng);
  for (auto _ : state) benchmark::DoNotOptimize(metric.distance(a, b));
}
BENCHMARK(BM_LpipsPair)->Args({1241, 376})->Args({620, 188})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
