// Forward orchestration of the CUDA rasterizer: per-Gaussian projection, depth sort, tile-entry
// emission in depth order, stable sort by tile, tile ranges, then the compositing (composite.cu).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <numeric>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/render/cuda/device_buffer.hpp"
#include "chungs/render/cuda/geometry.cuh"
#include "chungs/render/cuda/rasterizer.hpp"

namespace chungs::cuda {

using namespace detail;

namespace detail {

RasterConsts make_consts(const RasterConfig& c) {
  RasterConsts k;
  k.near_plane = float(c.near_plane);
  k.low_pass = float(c.low_pass);
  k.alpha_max = float(c.alpha_max);
  k.min_T = float(c.min_transmittance);
  k.extent_sigma = float(c.extent_sigma);
  k.guard_band = float(c.guard_band);
  k.min_alpha = float(c.min_alpha);
  k.log_min_alpha = c.min_alpha > 0 ? float(std::log(c.min_alpha)) : 0.f;
  for (int i = 0; i < 3; ++i) k.bg[i] = float(c.background[i]);
  k.sh_degree = c.sh_degree;
  k.antialias = c.antialias;
  return k;
}

}  // namespace detail

namespace {

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("CUDA rasterizer: ", what, ": ", cudaGetErrorString(e));
}

constexpr uint32_t kInvisibleKey = 0xFFFFFFFFu;

struct PreprocessOut {
  float4 *a, *b, *c;
  ushort4* rect;  // tile rectangle tx0, tx1, ty0, ty1
  uint32_t *tiles, *zkey, *order;
  float* radius;
  uint8_t* visible;
  // flags[0]: ~j for the smallest j whose slot is out of range (0: none); flags[2..3]: the tile entries
  // of all splats, 64 bits so that an overflow of the 32-bit entry lists is caught, not wrapped.
  uint32_t* flags;
};

// Projection of Gaussian ids[j] into splat j (cpu::project_splats + make_splat); returns its tiles.
__device__ uint32_t project_one(const GaussianArrays<float>& g, const uint32_t* __restrict__ ids, uint32_t j,
                                const RenderCamera<float>& cam, const RasterConsts& k, const PreprocessOut& o) {
  o.order[j] = j;
  o.tiles[j] = 0;
  o.zkey[j] = kInvisibleKey;
  o.visible[j] = 0;
  o.radius[j] = 0.f;
  const uint32_t slot = ids[j];
  if (slot >= g.capacity) {
    atomicMax(o.flags, ~j);
    return 0;
  }
  float shc[kShFloats], basis[kShCoeffs];
  load_sh(g.sh, slot, shc);
  Geometry G;
  if (!compute_geometry(g, slot, cam, k, shc, basis, G)) return 0;
  const float z = G.pc[2];
  const float mx = cam.fx * G.pc[0] / z + cam.cx, my = cam.fy * G.pc[1] / z + cam.cy;
  const float ca = G.C / G.det, cb = -G.B / G.det, cc = G.A / G.det;
  const float opacity = G.opacity * G.comp;
  if (!isfinite(mx) || !isfinite(my) || !isfinite(ca + cb + cc) || !isfinite(opacity) ||
      !isfinite(G.raw[0] + G.raw[1] + G.raw[2]))
    return 0;
  const float mid = (G.A + G.C) / 2, half = (G.A - G.C) / 2;
  const float radius = 3 * sqrtf(mid + sqrtf(half * half + G.B * G.B));
  float pmin = -0.5f * k.extent_sigma * k.extent_sigma;
  if (k.min_alpha > 0) pmin = fmaxf(pmin, k.log_min_alpha - logf(opacity));
  if (!(pmin < 0.f)) return 0;
  const float qmax = -2 * pmin;
  const float ex = sqrtf(qmax * G.A), ey = sqrtf(qmax * G.C);
  const float W1 = float(cam.width - 1), H1 = float(cam.height - 1);
  const float fx0 = ceilf(mx - ex), fx1 = floorf(mx + ex), fy0 = ceilf(my - ey), fy1 = floorf(my + ey);
  if (!(fx1 >= 0 && fx0 <= W1 && fy1 >= 0 && fy0 <= H1)) return 0;
  const int x0 = int(fmaxf(fx0, 0.f)), x1 = int(fminf(fx1, W1));
  const int y0 = int(fmaxf(fy0, 0.f)), y1 = int(fminf(fy1, H1));
  const int tx0 = x0 / kTileSize, tx1 = x1 / kTileSize, ty0 = y0 / kTileSize, ty1 = y1 / kTileSize;
  o.a[j] = make_float4(mx, my, opacity, pmin);
  o.b[j] = make_float4(ca, cb, cc, z);
  o.c[j] = make_float4(fmaxf(G.raw[0], 0.f), fmaxf(G.raw[1], 0.f), fmaxf(G.raw[2], 0.f), 1.f / z);
  o.rect[j] = make_ushort4(tx0, tx1, ty0, ty1);
  const uint32_t tiles = uint32_t(tx1 - tx0 + 1) * uint32_t(ty1 - ty0 + 1);
  o.tiles[j] = tiles;
  o.zkey[j] = __float_as_uint(z);  // z >= near > 0: the bit pattern orders like the value
  o.visible[j] = 1;
  o.radius[j] = radius;
  return tiles;
}

// The entries are counted here, not read from the end of the scan, so that the host can learn the count
// while the device sorts by depth: the forward's one wait for the host then leaves the device busy.
__global__ void preprocess_kernel(GaussianArrays<float> g, const uint32_t* __restrict__ ids, uint32_t n,
                                  RenderCamera<float> cam, RasterConsts k, PreprocessOut o) {
  const uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  const uint32_t tiles = j < n ? project_one(g, ids, j, cam, k, o) : 0u;
  // A splat covers at most all tiles, fewer than 2^27 (checked on the host): a warp's sum fits 32 bits.
  const uint32_t warp_sum = __reduce_add_sync(0xffffffffu, tiles);
  if ((threadIdx.x & 31) == 0 && warp_sum > 0)
    atomicAdd(reinterpret_cast<unsigned long long*>(o.flags + 2), (unsigned long long)warp_sum);
}

__global__ void gather_counts_kernel(const uint32_t* __restrict__ order, const uint32_t* __restrict__ tiles,
                                     uint32_t n, uint32_t* __restrict__ counts) {
  const uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r < n) counts[r] = tiles[order[r]];
}

// Splats in depth order write their entries at their offsets: entries are depth-ordered within
// every tile, and the stable sort by tile keeps that order. The 32 consecutive ranks of a warp own
// one contiguous run of entries, which the warp writes together (lane i writes entry run + i + 32 k
// after finding its owner by binary search over the lanes' starts), so the stores coalesce.
__global__ void __launch_bounds__(256)
    emit_kernel(const uint32_t* __restrict__ order, const uint32_t* __restrict__ ends,
                const ushort4* __restrict__ rects, const uint32_t* __restrict__ tiles, uint32_t n,
                int tiles_x, uint32_t* __restrict__ keys, uint32_t* __restrict__ vals) {
  __shared__ uint32_t s_start[8][32], s_j[8][32];
  __shared__ ushort4 s_rect[8][32];
  const uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  const int w = threadIdx.x >> 5, lane = threadIdx.x & 31;
  uint32_t j = 0, cnt = 0, end = ends[n - 1];
  if (r < n) {
    j = order[r];
    cnt = tiles[j];
    end = ends[r];
  }
  const uint32_t start = end - cnt;
  const uint32_t run_begin = __shfl_sync(0xffffffffu, start, 0), run_end = __shfl_sync(0xffffffffu, end, 31);
  s_start[w][lane] = start - run_begin;
  s_j[w][lane] = j;
  if (cnt > 0) s_rect[w][lane] = rects[j];
  __syncwarp();
  for (uint32_t p = run_begin + lane; p < run_end; p += 32) {
    const uint32_t rel = p - run_begin;
    // The last lane whose run starts at or before rel owns it (lanes with no entries start where
    // the next one does, so the last such lane is never empty).
    int lo = 0;
#pragma unroll
    for (int step = 16; step > 0; step >>= 1)
      if (s_start[w][lo + step] <= rel) lo += step;
    const uint32_t k = rel - s_start[w][lo];
    const ushort4 t = s_rect[w][lo];
    const uint32_t width = uint32_t(t.y - t.x + 1);
    keys[p] = (uint32_t(t.z) + k / width) * uint32_t(tiles_x) + uint32_t(t.x) + k % width;
    vals[p] = s_j[w][lo];
  }
}

__global__ void ranges_kernel(const uint32_t* __restrict__ keys, uint32_t total, uint2* __restrict__ ranges) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= total) return;
  const uint32_t t = keys[i];
  if (i == 0 || keys[i - 1] != t) ranges[t].x = i;
  if (i + 1 == total || keys[i + 1] != t) ranges[t].y = i + 1;
}

// Each tile's entries and its index, for the order in which the compositing takes the tiles.
__global__ void tile_work_kernel(const uint2* __restrict__ ranges, uint32_t ntiles, uint32_t* __restrict__ work,
                                 uint32_t* __restrict__ tiles) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= ntiles) return;
  work[t] = ranges[t].y - ranges[t].x;
  tiles[t] = t;
}

unsigned blocks_for(size_t n, unsigned threads) { return unsigned((n + threads - 1) / threads); }

int bits_for(uint32_t v) {
  int b = 0;
  while (b < 32 && (uint64_t(1) << b) <= v) ++b;
  return std::max(b, 1);
}

}  // namespace

struct CudaRasterizer::State {
  RasterConfig config;
  RasterConsts consts;
  bool timing = false;
  // ev[0..3]: the forward's stage boundaries, ev[4..6] the backward's; timed_*: recorded with timing on.
  cudaEvent_t ev[7] = {};
  bool timed_forward = false, timed_backward = false;
  cudaStream_t stream = nullptr;  // legacy default stream
  // Last forward.
  bool have_forward = false;
  GaussianArrays<float> g;
  const uint32_t* ids = nullptr;
  size_t n = 0;
  RenderCamera<float> cam;
  int tiles_x = 0, tiles_y = 0;
  uint32_t total = 0;
  DeviceRenderOutput out;
  DeviceGaussianGrads grads;
  // Per splat.
  DeviceArray<float4> a, b, c;
  DeviceArray<ushort4> rect;
  DeviceArray<uint32_t> tiles, zkey, zkey_sorted, order, order_sorted, ends;
  DeviceArray<float> radius;
  DeviceArray<uint8_t> visible;
  // Per tile entry, per tile, per pixel.
  DeviceArray<uint32_t> keys, keys_sorted, vals, vals_sorted;
  DeviceArray<uint2> ranges;
  DeviceArray<uint32_t> tile_work, tile_work_sorted, tile_ids, tile_order;  // most entries first
  // Crowded tiles in segments (kernels.cuh): per tile, per work item, per split item's pixel.
  DeviceArray<uint32_t> tile_segments, tile_first_item, item_counts;
  DeviceArray<uint4> items;
  DeviceArray<float> segment_values;
  TileSegments segments{};
  DeviceArray<float> rgb, depth, inv_depth, alpha;
  DeviceArray<uint32_t> top_id, last;
  DeviceBytes temp;
  DeviceArray<uint32_t> flags;     // PreprocessOut::flags
  uint32_t* host_flags = nullptr;  // pinned copy of flags (PreprocessOut)
  cudaEvent_t counted = nullptr;   // flags have reached host_flags
  // Backward.
  DeviceArray<float> splat_grads, g_mean, g_scale, g_rot, g_op, g_sh;

  State() {
    for (auto& e : ev) check(cudaEventCreate(&e), "cudaEventCreate");
    check(cudaEventCreateWithFlags(&counted, cudaEventDisableTiming), "cudaEventCreate");
    check(cudaMallocHost(&host_flags, 4 * sizeof(uint32_t)), "cudaMallocHost");
    flags.resize(4);
    item_counts.resize(2);
  }
  ~State() {
    for (auto& e : ev) cudaEventDestroy(e);
    cudaEventDestroy(counted);
    cudaFreeHost(host_flags);
  }
  void mark(int i) {
    if (timing) check(cudaEventRecord(ev[i], stream), "cudaEventRecord");
  }
  double elapsed(int i0, int i1) const {
    float ms = 0;
    check(cudaEventSynchronize(ev[i1]), "cudaEventSynchronize");
    check(cudaEventElapsedTime(&ms, ev[i0], ev[i1]), "cudaEventElapsedTime");
    return ms;
  }
  void* scratch(size_t bytes) {
    temp.reserve(std::max<size_t>(bytes, 1));
    return temp.data();
  }
};

CudaRasterizer::CudaRasterizer(const RasterConfig& config) : s_(std::make_unique<State>()) {
  set_config(config);
}
CudaRasterizer::~CudaRasterizer() = default;

const RasterConfig& CudaRasterizer::config() const { return s_->config; }
void CudaRasterizer::set_config(const RasterConfig& config) {
  config.validate();
  s_->config = config;
  s_->consts = make_consts(config);
  s_->have_forward = false;
}
void CudaRasterizer::enable_timings(bool on) { s_->timing = on; }
const DeviceRenderOutput& CudaRasterizer::output() const { return s_->out; }
CudaRasterTimings CudaRasterizer::timings() const {
  const State& s = *s_;
  CudaRasterTimings t;
  if (s.timed_forward) {
    t.preprocess = s.elapsed(0, 1), t.sort = s.elapsed(1, 2), t.composite = s.elapsed(2, 3);
    std::vector<uint2> ranges;
    s.ranges.download(ranges);
    std::vector<uint32_t> counts;
    for (const uint2& r : ranges) counts.push_back(r.y - r.x);
    std::sort(counts.begin(), counts.end(), std::greater<>());
    if (!counts.empty() && s.total > 0) {
      t.largest_tile = counts[0];
      const size_t top = std::max<size_t>(1, counts.size() / 100);
      t.top_percent_share =
          double(std::accumulate(counts.begin(), counts.begin() + top, uint64_t(0))) / s.total;
    }
  }
  if (s.timed_backward) t.composite_backward = s.elapsed(4, 5), t.project_backward = s.elapsed(5, 6);
  return t;
}
size_t CudaRasterizer::tile_entries() const { return s_->total; }
size_t CudaRasterizer::split_items() const {
  if (!s_->have_forward) return 0;
  uint32_t counts[2] = {0, 0};
  check(cudaMemcpy(counts, s_->item_counts.data(), sizeof counts, cudaMemcpyDeviceToHost),
        "copy item counts");
  return counts[1];
}

const DeviceRenderOutput& CudaRasterizer::forward(const GaussianArrays<float>& g, const uint32_t* ids,
                                                  size_t n, const RenderCamera<float>& cam) {
  State& s = *s_;
  if (cam.width <= 0 || cam.height <= 0)
    fail("CUDA rasterizer: image size must be positive, got ", cam.width, "x", cam.height);
  if (!(cam.fx > 0 && cam.fy > 0)) fail("CUDA rasterizer: focal lengths must be positive");
  s.consts.low_pass = float(s.config.low_pass_for(cam.width, cam.height));  // the backward uses it too
  if (n >= 0xFFFFFFFFu) fail("CUDA rasterizer: ", n, " indices is more than 2^32 - 1");
  if (n > 0) {
    if (!g.mean || !g.log_scale || !g.rotation || !g.opacity || !g.sh || !ids)
      fail("CUDA rasterizer: Gaussian arrays or index list missing (null pointer) for ", n, " indices");
    if (reinterpret_cast<uintptr_t>(g.rotation) % 16 || reinterpret_cast<uintptr_t>(g.sh) % 16)
      fail("CUDA rasterizer: rotation and SH arrays must be 16-byte aligned");
  }
  const int W = cam.width, H = cam.height;
  s.tiles_x = (W + kTileSize - 1) / kTileSize;
  s.tiles_y = (H + kTileSize - 1) / kTileSize;
  if (uint64_t(s.tiles_x) * uint64_t(s.tiles_y) >= (uint64_t(1) << 27))
    fail("CUDA rasterizer: an image of ", W, "x", H, " has more tiles than a render can count (2^27)");
  const uint32_t ntiles = uint32_t(s.tiles_x) * uint32_t(s.tiles_y);
  s.g = g, s.ids = ids, s.n = n, s.cam = cam;
  s.have_forward = false;
  const size_t npix = size_t(W) * H;
  s.rgb.resize(3 * npix), s.depth.resize(npix), s.inv_depth.resize(npix), s.alpha.resize(npix);
  s.top_id.resize(npix), s.last.resize(npix), s.ranges.resize(ntiles);
  for (auto* arr :
       {&s.tile_work, &s.tile_work_sorted, &s.tile_ids, &s.tile_order, &s.tile_segments, &s.tile_first_item})
    arr->resize(ntiles);
  for (auto* arr : {&s.tiles, &s.zkey, &s.zkey_sorted, &s.order, &s.order_sorted, &s.ends}) arr->resize(n);
  s.a.resize(n), s.b.resize(n), s.c.resize(n), s.rect.resize(n), s.radius.resize(n), s.visible.resize(n);
  cudaStream_t st = s.stream;

  s.mark(0);
  s.total = 0;
  if (n > 0) {
    check(cudaMemsetAsync(s.flags.data(), 0, 4 * sizeof(uint32_t), st), "memset");
    PreprocessOut po{s.a.data(),    s.b.data(),     s.c.data(),      s.rect.data(),    s.tiles.data(),
                     s.zkey.data(), s.order.data(), s.radius.data(), s.visible.data(), s.flags.data()};
    preprocess_kernel<<<blocks_for(n, 128), 128, 0, st>>>(g, ids, uint32_t(n), cam, s.consts, po);
    check(cudaGetLastError(), "preprocess launch");
    check(cudaMemcpyAsync(s.host_flags, s.flags.data(), 4 * sizeof(uint32_t), cudaMemcpyDeviceToHost, st),
          "copy flags");
    check(cudaEventRecord(s.counted, st), "record count");
    s.mark(1);
    size_t bytes = 0, scan_bytes = 0;
    cub::DeviceRadixSort::SortPairs(nullptr, bytes, s.zkey.data(), s.zkey_sorted.data(), s.order.data(),
                                    s.order_sorted.data(), int(n), 0, 32, st);
    cub::DeviceScan::InclusiveSum(nullptr, scan_bytes, s.tiles.data(), s.ends.data(), int(n), st);
    void* tmp = s.scratch(std::max(bytes, scan_bytes));
    check(cub::DeviceRadixSort::SortPairs(tmp, bytes, s.zkey.data(), s.zkey_sorted.data(), s.order.data(),
                                          s.order_sorted.data(), int(n), 0, 32, st),
          "depth sort");
    // zkey is free now: it holds the per-rank counts.
    gather_counts_kernel<<<blocks_for(n, 256), 256, 0, st>>>(s.order_sorted.data(), s.tiles.data(),
                                                             uint32_t(n), s.zkey.data());
    check(cub::DeviceScan::InclusiveSum(tmp, scan_bytes, s.zkey.data(), s.ends.data(), int(n), st), "scan");
    check(cudaEventSynchronize(s.counted), "preprocess");  // the sort and the scan run meanwhile
    if (s.host_flags[0] != 0) {
      const uint32_t j = ~s.host_flags[0];
      uint32_t slot = 0;
      check(cudaMemcpy(&slot, ids + j, sizeof slot, cudaMemcpyDeviceToHost), "copy bad index");
      fail("CUDA rasterizer: index ", j, " names slot ", slot, " but the arrays hold ", g.capacity, " slots");
    }
    uint64_t entries = 0;
    std::memcpy(&entries, s.host_flags + 2, sizeof entries);
    if (entries > 0xFFFFFFFFull)
      fail("CUDA rasterizer: ", n, " splats cover ", entries, " tiles of ", W, "x", H,
           ", more than the 2^32 - 1 tile entries a render can hold");
    s.total = uint32_t(entries);
  } else {
    s.mark(1);
  }
  const uint32_t total = s.total;
  check(cudaMemsetAsync(s.ranges.data(), 0, ntiles * sizeof(uint2), st), "memset ranges");
  if (total > 0) {
    s.keys.resize(total), s.vals.resize(total), s.keys_sorted.resize(total), s.vals_sorted.resize(total);
    emit_kernel<<<blocks_for(n, 256), 256, 0, st>>>(s.order_sorted.data(), s.ends.data(), s.rect.data(),
                                                    s.tiles.data(), uint32_t(n), s.tiles_x, s.keys.data(),
                                                    s.vals.data());
    check(cudaGetLastError(), "emit launch");
    const int bits = bits_for(ntiles);
    size_t bytes = 0;
    cub::DeviceRadixSort::SortPairs(nullptr, bytes, s.keys.data(), s.keys_sorted.data(), s.vals.data(),
                                    s.vals_sorted.data(), int(total), 0, bits, st);
    check(cub::DeviceRadixSort::SortPairs(s.scratch(bytes), bytes, s.keys.data(), s.keys_sorted.data(),
                                          s.vals.data(), s.vals_sorted.data(), int(total), 0, bits, st),
          "tile sort");
    ranges_kernel<<<blocks_for(total, 256), 256, 0, st>>>(s.keys_sorted.data(), total, s.ranges.data());
    check(cudaGetLastError(), "ranges launch");
  }
  // Crowded tiles first (a stable sort: tiles of equal work keep their row-major order).
  tile_work_kernel<<<blocks_for(ntiles, 256), 256, 0, st>>>(s.ranges.data(), ntiles, s.tile_work.data(),
                                                            s.tile_ids.data());
  check(cudaGetLastError(), "tile work launch");
  {
    const int bits = bits_for(total);
    size_t bytes = 0;
    cub::DeviceRadixSort::SortPairsDescending(nullptr, bytes, s.tile_work.data(), s.tile_work_sorted.data(),
                                              s.tile_ids.data(), s.tile_order.data(), int(ntiles), 0, bits, st);
    check(cub::DeviceRadixSort::SortPairsDescending(s.scratch(bytes), bytes, s.tile_work.data(),
                                                    s.tile_work_sorted.data(), s.tile_ids.data(),
                                                    s.tile_order.data(), int(ntiles), 0, bits, st),
          "tile order");
  }
  {
    // Work items: tiles, the crowded ones cut into segments. A tile of e entries makes ceil(e / segment)
    // <= e / segment + 1 items, so all items number at most tiles + total / segment, and those of split
    // tiles (e > segment: at most total / segment such tiles) at most total / segment + min(tiles, that).
    const uint32_t segment = uint32_t(s.config.segment_entries);
    const uint32_t per = segment > 0 ? total / segment : 0;
    s.segments.segment = segment;
    s.segments.grid = ntiles + per;
    s.segments.split_grid = per + std::min(ntiles, per);
    s.items.resize(s.segments.grid);
    s.segment_values.resize(size_t(s.segments.split_grid) * kSegmentValues * kBlock);
    const size_t bytes = tile_segments_scratch_bytes(ntiles);
    build_tile_segments(s.ranges.data(), ntiles, segment, s.tile_order.data(), s.tile_segments.data(),
                        s.tile_first_item.data(), s.items.data(), s.item_counts.data(), s.scratch(bytes),
                        bytes, st);
    check(cudaGetLastError(), "tile segments");
    s.segments.items = s.items.data();
    s.segments.counts = s.item_counts.data();
    s.segments.seg = s.segment_values.data();
  }
  s.mark(2);
  composite_forward(s.ranges.data(), s.segments, s.vals_sorted.data(),
                    SplatData{s.a.data(), s.b.data(), s.c.data()}, ids, W, H, s.consts,
                    ForwardImages{s.rgb.data(), s.depth.data(), s.inv_depth.data(), s.alpha.data(),
                                  s.top_id.data(), s.last.data()},
                    st);
  check(cudaGetLastError(), "composite launch");
  s.mark(3);
  s.timed_forward = s.timing, s.timed_backward = false;
  s.out = DeviceRenderOutput{W,
                             H,
                             n,
                             s.rgb.data(),
                             s.depth.data(),
                             s.inv_depth.data(),
                             s.alpha.data(),
                             s.top_id.data(),
                             s.visible.data(),
                             s.radius.data()};
  s.have_forward = true;
  return s.out;
}

const DeviceGaussianGrads& CudaRasterizer::backward(const DeviceRenderGrads& dloss) {
  State& s = *s_;
  if (!s.have_forward) fail("CUDA rasterizer backward: no forward render to differentiate");
  const size_t n = s.n;
  cudaStream_t st = s.stream;
  s.splat_grads.resize(n * kSplatGrads);
  s.g_mean.resize(3 * n), s.g_scale.resize(3 * n), s.g_rot.resize(4 * n), s.g_op.resize(n);
  s.g_sh.resize(size_t(kShFloats) * n);
  s.grads =
      DeviceGaussianGrads{n, s.g_mean.data(), s.g_scale.data(), s.g_rot.data(), s.g_op.data(), s.g_sh.data()};
  s.mark(4);
  if (n > 0) check(cudaMemsetAsync(s.splat_grads.data(), 0, n * kSplatGrads * sizeof(float), st), "memset");
  if (n > 0 && s.total > 0)
    composite_backward(s.ranges.data(), s.segments, s.vals_sorted.data(),
                       SplatData{s.a.data(), s.b.data(), s.c.data()}, s.cam.width, s.cam.height, s.consts,
                       s.rgb.data(), s.depth.data(), s.inv_depth.data(), s.alpha.data(), s.last.data(), dloss,
                       s.splat_grads.data(), st);
  check(cudaGetLastError(), "composite backward launch");
  s.mark(5);
  if (n > 0)
    gaussian_backward(s.g, s.ids, n, s.cam, s.consts, s.visible.data(), s.splat_grads.data(), s.grads, st);
  check(cudaGetLastError(), "Gaussian backward launch");
  s.mark(6);
  s.timed_backward = s.timing && s.timed_forward;
  return s.grads;
}

void CudaRasterizer::download(RenderOutput<float>& out) const {
  const State& s = *s_;
  if (!s.have_forward) fail("CUDA rasterizer: nothing rendered to download");
  const int W = s.cam.width, H = s.cam.height;
  out.rgb = Image<float>(W, H, 3), out.depth = Image<float>(W, H, 1), out.inv_depth = Image<float>(W, H, 1);
  out.alpha = Image<float>(W, H, 1), out.top_id = Image<uint32_t>(W, H, 1);
  s.rgb.download(out.rgb.vec()), s.depth.download(out.depth.vec()), s.inv_depth.download(out.inv_depth.vec());
  s.alpha.download(out.alpha.vec()), s.top_id.download(out.top_id.vec());
  s.visible.download(out.visible), s.radius.download(out.radius);
}

void CudaRasterizer::download(GaussianGrads<float>& grads) const {
  const State& s = *s_;
  if (s.grads.count != s.n || !s.have_forward) fail("CUDA rasterizer: no backward to download");
  s.g_mean.download(grads.mean), s.g_scale.download(grads.log_scale), s.g_rot.download(grads.rotation);
  s.g_op.download(grads.opacity), s.g_sh.download(grads.sh);
}

}  // namespace chungs::cuda
