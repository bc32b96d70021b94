// CPU reference rasterizer: forward and forward+backward time on the shared benchmark workload
// (chungs/render/bench_scene.hpp) at 640x480 and 1241x376 with 100k and 500k Gaussians.
// Counters: ms per stage of the last iteration and the number of (tile, Gaussian) pairs.
#include "chungs/render/cpu/rasterizer.hpp"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <map>
#include <memory>
#include <vector>

#include "chungs/geometry/se3.hpp"
#include "chungs/render/bench_scene.hpp"

namespace {

using namespace chungs;

struct Workload {
  Camera camera;
  GaussianParams gaussians;
  std::vector<uint32_t> ids;
  RenderGrads<float> dloss;
};

const Workload& workload(int resolution, int n) {
  static std::map<std::pair<int, int>, std::unique_ptr<Workload>> cache;
  auto& w = cache[{resolution, n}];
  if (!w) {
    w = std::make_unique<Workload>();
    w->camera = resolution == 0 ? bench_camera_vga() : bench_camera_kitti();
    w->gaussians = make_bench_gaussians(size_t(n), w->camera);
    w->ids.resize(size_t(n));
    for (int i = 0; i < n; ++i) w->ids[size_t(i)] = uint32_t(i);
    // d(sum image * weights)/d(image) = weights.
    w->dloss.rgb = make_bench_weights(w->camera.width, w->camera.height);
  }
  return *w;
}

void report(benchmark::State& state, const CpuRasterizer<float>& r, bool backward) {
  const RasterTimings& t = r.timings();
  state.counters["project_ms"] = t.project;
  state.counters["bin_ms"] = t.bin;
  state.counters["composite_ms"] = t.composite;
  if (backward) {
    state.counters["bwd_composite_ms"] = t.composite_backward;
    state.counters["bwd_project_ms"] = t.project_backward;
  }
  state.counters["tile_pairs"] = double(r.tile_entries());
  int visible = 0;
  for (uint8_t v : r.output().visible) visible += v;
  state.counters["visible"] = visible;
}

// Sets the OpenMP thread count for one benchmark and restores it afterwards.
struct Threads {
  int saved = omp_get_max_threads();
  explicit Threads(int n) { omp_set_num_threads(n > 0 ? n : saved); }
  ~Threads() { omp_set_num_threads(saved); }
};

void BM_Forward(benchmark::State& state) {
  const Workload& w = workload(int(state.range(0)), int(state.range(1)));
  const Threads threads(int(state.range(2)));
  CpuRasterizer<float> r;
  const auto cam = make_render_camera<float>(w.camera, SE3());
  for (auto _ : state) benchmark::DoNotOptimize(r.forward(view_of(w.gaussians), w.ids, cam).rgb.data());
  report(state, r, false);
}

void BM_ForwardBackward(benchmark::State& state) {
  const Workload& w = workload(int(state.range(0)), int(state.range(1)));
  const Threads threads(int(state.range(2)));
  CpuRasterizer<float> r;
  const auto cam = make_render_camera<float>(w.camera, SE3());
  GaussianGrads<float> grads;
  for (auto _ : state) {
    r.forward(view_of(w.gaussians), w.ids, cam);
    r.backward(w.dloss, grads);
    benchmark::DoNotOptimize(grads.mean.data());
  }
  report(state, r, true);
}

// Arguments: resolution (0 = 640x480 f 525, 1 = 1241x376 f 718), number of Gaussians, OpenMP
// threads (0 = all; 1 gives a per-core figure that is steadier on a shared machine).
void args(benchmark::internal::Benchmark* b) {
  for (int threads : {0, 1})
    for (int res : {0, 1})
      for (int n : {100000, 500000}) b->Args({res, n, threads});
  b->ArgNames({"res", "n", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
}

BENCHMARK(BM_Forward)->Apply(args);
BENCHMARK(BM_ForwardBackward)->Apply(args);

}  // namespace

BENCHMARK_MAIN();
