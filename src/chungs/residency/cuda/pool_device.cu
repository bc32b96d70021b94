// Transfers of the CUDA Gaussian pool: a chunk's arrays are packed into a pinned staging buffer
// (array after array), copied in one transfer on the pool's own non-blocking stream, and scattered
// into their slots by one kernel (gathered the reverse way), so loads and evictions overlap with
// the optimiser's work on the default stream. Two staging buffers alternate. They have a fixed size,
// allocated with the pool, and larger batches move in pieces: staging that grew to the largest
// batch seen raised host RSS by ~80 MB in one step, minutes into a long run, at the first burst of
// chunk loads (pinned pages are resident), where memory must stay level once the budget is full.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/residency/cuda/pool_device.hpp"

namespace chungs::cuda::detail {

namespace {

constexpr int kMaxArrays = 24;
// ~12 MB of pinned memory per staging buffer at SH degree 3 with Adam moments: a transfer of that
// size already runs near the link's rate, and a typical chunk moves in one piece.
constexpr size_t kPieceGaussians = size_t(1) << 14;

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("CUDA Gaussian pool: ", what, ": ", cudaGetErrorString(e));
}

struct Layout {
  uint32_t* arrays[kMaxArrays];
  int width[kMaxArrays];
  size_t offset[kMaxArrays];  // start of array a in the staging buffer, in elements
  int count;
};

// Element e of array blockIdx.y: staging[offset + e] <-> array[slot * width + k].
template <bool Scatter>
__global__ void move_kernel(Layout L, uint32_t* __restrict__ staging, const uint32_t* __restrict__ slots,
                            size_t n) {
  const int a = blockIdx.y;
  const int w = L.width[a];
  const size_t total = n * size_t(w);
  for (size_t e = size_t(blockIdx.x) * blockDim.x + threadIdx.x; e < total;
       e += size_t(gridDim.x) * blockDim.x) {
    const size_t i = e / w, k = e % w;
    uint32_t* dst = L.arrays[a] + size_t(slots[i]) * w + k;
    uint32_t* st = staging + L.offset[a] + e;
    if (Scatter)
      *dst = *st;
    else
      *st = *dst;
  }
}

struct Staging {
  uint32_t* host = nullptr;  // pinned
  uint32_t* device = nullptr;
  size_t capacity = 0;         // elements
  cudaEvent_t done = nullptr;  // the last transfer that used this buffer
};

}  // namespace

struct PoolDevice {
  size_t capacity = 0;
  int count = 0;
  std::vector<int> widths;
  std::vector<uint32_t*> arrays;
  cudaStream_t stream = nullptr;
  cudaEvent_t compute_done = nullptr, uploads_done = nullptr;
  Staging staging[2];
  int next = 0;

  ~PoolDevice() {
    if (stream) cudaStreamSynchronize(stream);
    for (auto* p : arrays) cudaFree(p);
    for (auto& s : staging) {
      cudaFreeHost(s.host);
      cudaFree(s.device);
      if (s.done) cudaEventDestroy(s.done);
    }
    if (compute_done) cudaEventDestroy(compute_done);
    if (uploads_done) cudaEventDestroy(uploads_done);
    if (stream) cudaStreamDestroy(stream);
  }

  // Both staging buffers, each for one piece of pool_device_piece() Gaussians and their slots.
  void allocate_staging() {
    size_t elems = kPieceGaussians;
    for (int w : widths) elems += kPieceGaussians * size_t(w);
    for (auto& s : staging) {
      check(cudaMallocHost(&s.host, elems * 4), "pinned staging allocation");
      check(cudaMalloc(&s.device, elems * 4), "device staging allocation");
      s.capacity = elems;
      check(cudaEventCreateWithFlags(&s.done, cudaEventDisableTiming), "event");
    }
  }

  // The next staging buffer, free of pending transfers.
  Staging& take() {
    Staging& s = staging[next];
    next ^= 1;
    check(cudaEventSynchronize(s.done), "staging wait");
    return s;
  }

  Layout layout(size_t n, size_t& total) const {
    Layout L{};
    L.count = count;
    total = 0;
    for (int a = 0; a < count; ++a) {
      L.arrays[a] = arrays[a];
      L.width[a] = widths[a];
      L.offset[a] = total;
      total += n * size_t(widths[a]);
    }
    return L;
  }

  void after_compute() {
    check(cudaEventRecord(compute_done, 0), "event record");
    check(cudaStreamWaitEvent(stream, compute_done, 0), "stream wait");
  }

  void launch(bool scatter, const Layout& L, uint32_t* staging_dev, const uint32_t* slots_dev, size_t n) {
    size_t widest = 0;
    for (int a = 0; a < count; ++a) widest = std::max(widest, n * size_t(widths[a]));
    const unsigned blocks = unsigned(std::min<size_t>((widest + 255) / 256, 4096));
    const dim3 grid(std::max(blocks, 1u), unsigned(count));
    if (scatter)
      move_kernel<true><<<grid, 256, 0, stream>>>(L, staging_dev, slots_dev, n);
    else
      move_kernel<false><<<grid, 256, 0, stream>>>(L, staging_dev, slots_dev, n);
    check(cudaGetLastError(), "copy kernel");
  }
};

PoolDevice* pool_device_create(size_t capacity, const int* widths, int count) {
  if (count > kMaxArrays) fail("CUDA Gaussian pool: ", count, " arrays, at most ", kMaxArrays);
  auto* d = new PoolDevice;
  try {
    d->capacity = capacity;
    d->count = count;
    d->widths.assign(widths, widths + count);
    for (int a = 0; a < count; ++a) {
      void* p = nullptr;
      const size_t bytes = std::max<size_t>(capacity * size_t(widths[a]) * 4, 4);
      check(cudaMalloc(&p, bytes), "array allocation");
      d->arrays.push_back(static_cast<uint32_t*>(p));
    }
    check(cudaStreamCreateWithFlags(&d->stream, cudaStreamNonBlocking), "stream");
    check(cudaEventCreateWithFlags(&d->compute_done, cudaEventDisableTiming), "event");
    check(cudaEventCreateWithFlags(&d->uploads_done, cudaEventDisableTiming), "event");
    d->allocate_staging();
  } catch (...) {
    delete d;
    throw;
  }
  return d;
}

void pool_device_grow(PoolDevice* d, size_t capacity) {
  if (capacity <= d->capacity) return;
  // Behind the renders and updates queued on the default stream and the pool's own scatters; rare
  // (the pool doubles), so host waits are cheap here.
  d->after_compute();
  check(cudaStreamSynchronize(d->stream), "growth wait");
  // Array by array, so the device holds the old arrays and the new ones together only for one
  // kind at a time (at most ~1/4 of the old pool beyond the new one).
  for (size_t a = 0; a < d->arrays.size(); ++a) {
    void* p = nullptr;
    check(cudaMalloc(&p, capacity * size_t(d->widths[a]) * 4), "array growth");
    const size_t bytes = d->capacity * size_t(d->widths[a]) * 4;
    cudaError_t e = cudaMemcpyAsync(p, d->arrays[a], bytes, cudaMemcpyDeviceToDevice, d->stream);
    if (e == cudaSuccess) e = cudaStreamSynchronize(d->stream);  // the old array is freed next
    if (e != cudaSuccess) cudaFree(p);
    check(e, "array growth copy");
    cudaFree(d->arrays[a]);
    d->arrays[a] = static_cast<uint32_t*>(p);
  }
  d->capacity = capacity;
}

void pool_device_destroy(PoolDevice* d) { delete d; }

void* pool_device_array(PoolDevice* d, int array) { return d->arrays.at(size_t(array)); }

size_t pool_device_piece() { return kPieceGaussians; }

namespace {
// Array a (w elements a Gaussian) of Gaussians [first, first + m) of the blocks laid end to end,
// to the staging buffer or back from it.
void pack(const HostArrays* blocks, size_t block_count, int a, size_t w, size_t first, size_t m, uint32_t* staging,
          bool to_staging) {
  size_t base = 0;  // the first Gaussian of block b
  for (size_t b = 0; b < block_count && m > 0; base += blocks[b].count, ++b) {
    const size_t end = base + blocks[b].count;
    if (end <= first) continue;
    const size_t take = std::min(m, end - first);
    auto* host = static_cast<uint32_t*>(const_cast<void*>(blocks[b].data[a])) + (first - base) * w;
    if (to_staging)
      std::memcpy(staging, host, take * w * 4);
    else
      std::memcpy(host, staging, take * w * 4);
    staging += take * w;
    first += take;
    m -= take;
  }
}
}  // namespace

void pool_device_scatter(PoolDevice* d, const HostArrays* blocks, size_t block_count, const uint32_t* slots,
                         size_t n) {
  for (size_t first = 0; first < n; first += kPieceGaussians) {
    const size_t m = std::min(kPieceGaussians, n - first);
    size_t total = 0;
    const Layout L = d->layout(m, total);
    Staging& s = d->take();
    for (int a = 0; a < d->count; ++a)
      pack(blocks, block_count, a, size_t(d->widths[a]), first, m, s.host + L.offset[a], true);
    std::memcpy(s.host + total, slots + first, m * 4);
    check(cudaMemcpyAsync(s.device, s.host, (total + m) * 4, cudaMemcpyHostToDevice, d->stream), "upload");
    d->after_compute();  // slots being overwritten may still be read by queued renders
    d->launch(true, L, s.device, s.device + total, m);
    check(cudaEventRecord(s.done, d->stream), "event record");
    check(cudaEventRecord(d->uploads_done, d->stream), "event record");
  }
}

void pool_device_gather(PoolDevice* d, const HostArrays* blocks, size_t block_count, const uint32_t* slots,
                        size_t n) {
  for (size_t first = 0; first < n; first += kPieceGaussians) {
    const size_t m = std::min(kPieceGaussians, n - first);
    size_t total = 0;
    const Layout L = d->layout(m, total);
    Staging& s = d->take();
    std::memcpy(s.host + total, slots + first, m * 4);
    check(cudaMemcpyAsync(s.device + total, s.host + total, m * 4, cudaMemcpyHostToDevice, d->stream), "slots");
    d->after_compute();  // the optimiser's queued updates come first
    d->launch(false, L, s.device, s.device + total, m);
    check(cudaMemcpyAsync(s.host, s.device, total * 4, cudaMemcpyDeviceToHost, d->stream), "download");
    check(cudaEventRecord(s.done, d->stream), "event record");
    check(cudaEventSynchronize(s.done), "download wait");
    for (int a = 0; a < d->count; ++a)
      pack(blocks, block_count, a, size_t(d->widths[a]), first, m, s.host + L.offset[a], false);
  }
}

void pool_device_wait_uploads(PoolDevice* d) {
  check(cudaStreamWaitEvent(0, d->uploads_done, 0), "stream wait");
}

void pool_device_synchronize(PoolDevice* d) { check(cudaStreamSynchronize(d->stream), "synchronize"); }

}  // namespace chungs::cuda::detail
