// Frustum culling of a large map at the paper's 100 m far plane: the hierarchical culler on one
// and two threads, the brute-force loop it must agree with, a per-keyframe cache hit, and what a change of
// the map's chunk set costs (the octree and the id set that names each visible cube at its level).
// Map: 400 x 400 chunks in 3 height layers (4 km square at 10 m chunks; 800 m at 2 m chunks, where
// many more chunks lie within 100 m), a given share of them present;
// a KITTI-like camera (1241 x 376, f = 718) at ground level looking horizontally.
//
//   bench_culling --benchmark_out=culling.json
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <unordered_set>

#include "chungs/residency/frustum_culler.hpp"

using namespace chungs;

namespace {

std::vector<ChunkId> make_map(double fill) {
  std::mt19937 rng(7);
  std::bernoulli_distribution keep(fill);
  std::vector<ChunkId> ids;
  for (int x = -200; x < 200; ++x)
    for (int z = -200; z < 200; ++z)
      for (int y = -1; y <= 1; ++y)
        if (keep(rng)) ids.push_back(chunk_id({x, y, z}));
  return ids;
}

const Camera kKitti(1241, 376, 718.856, 718.856, 607.19, 185.22);

// Positions inside the mapped area (which spans +-200 chunks).
std::vector<SE3> make_poses(int n, double chunk_size = 10.0) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> pos(-180 * chunk_size, 180 * chunk_size), yaw(-M_PI, M_PI);
  std::vector<SE3> poses;
  for (int i = 0; i < n; ++i) {
    // Camera y axis points down (OpenCV); yaw about the world y axis keeps it level.
    const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw(rng), Eigen::Vector3d::UnitY()));
    poses.emplace_back(q, Eigen::Vector3d(pos(rng), 1.5, pos(rng)));
  }
  return poses;
}

FrustumCuller& culler_for(double fill, double chunk_size = 10.0) {
  static std::map<std::pair<double, double>, std::unique_ptr<FrustumCuller>> cullers;
  auto& c = cullers[{fill, chunk_size}];
  if (!c) {
    CullerConfig cfg;
    cfg.parallel_min_chunks = 1;  // always the parallel path; threads set per benchmark
    c = std::make_unique<FrustumCuller>(chunk_size, cfg);
    c->set_chunks(make_map(fill), 1);
  }
  return *c;
}

void BM_CullHierarchical(benchmark::State& st) {
  const double fill = double(st.range(0)) / 100.0;
  omp_set_num_threads(int(st.range(1)));
  FrustumCuller& culler = culler_for(fill, double(st.range(2)));
  const auto poses = make_poses(256, double(st.range(2)));
  size_t i = 0, visible = 0;
  for (auto _ : st) {
    auto v = culler.cull(kKitti, poses[i++ % poses.size()]);
    visible += v.size();
    benchmark::DoNotOptimize(v.data());
  }
  st.counters["chunks"] = double(culler.chunk_count());
  st.counters["visible_avg"] = double(visible) / double(st.iterations());
}

void BM_CullBruteForce(benchmark::State& st) {
  const double fill = double(st.range(0)) / 100.0;
  FrustumCuller& culler = culler_for(fill, double(st.range(1)));
  const auto poses = make_poses(256, double(st.range(1)));
  size_t i = 0;
  for (auto _ : st) {
    auto v = culler.cull_brute_force(kKitti, poses[i++ % poses.size()]);
    benchmark::DoNotOptimize(v.data());
  }
  st.counters["chunks"] = double(culler.chunk_count());
}

void BM_CullCacheHit(benchmark::State& st) {
  FrustumCuller& culler = culler_for(0.3);
  const SE3 pose = make_poses(1)[0];
  culler.cull_cached(1, kKitti, pose);
  for (auto _ : st) {
    auto v = culler.cull_cached(1, kKitti, pose);
    benchmark::DoNotOptimize(v.data());
  }
}

// Once per change of the map's chunks (about once a keyframe while the map grows).
void BM_SetChunks(benchmark::State& st) {
  const std::vector<ChunkId> ids = make_map(double(st.range(0)) / 100.0);
  FrustumCuller culler(10.0, CullerConfig{});
  uint64_t version = 0;
  for (auto _ : st) culler.set_chunks(ids, ++version);
  st.counters["chunks"] = double(ids.size());
}

// The id set alone, the part of set_chunks that two levels per chunk added.
void BM_ChunkIdSet(benchmark::State& st) {
  const std::vector<ChunkId> ids = make_map(double(st.range(0)) / 100.0);
  for (auto _ : st) {
    std::unordered_set<ChunkId> set;
    set.reserve(ids.size());
    set.insert(ids.begin(), ids.end());
    benchmark::DoNotOptimize(set.size());
  }
  st.counters["chunks"] = double(ids.size());
}

}  // namespace

BENCHMARK(BM_CullHierarchical)->ArgNames({"fill_pct", "threads", "chunk_m"})
    ->Args({5, 1, 10})->Args({30, 1, 10})->Args({30, 2, 10})->Args({100, 1, 10})->Args({100, 2, 10})
    ->Args({100, 1, 2})->Args({100, 2, 2})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CullBruteForce)->ArgNames({"fill_pct", "chunk_m"})
    ->Args({5, 10})->Args({30, 10})->Args({100, 10})->Args({100, 2})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CullCacheHit)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SetChunks)->ArgNames({"fill_pct"})->Arg(5)->Arg(30)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ChunkIdSet)->ArgNames({"fill_pct"})->Arg(5)->Arg(30)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
