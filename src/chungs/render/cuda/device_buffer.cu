#include <cuda_runtime.h>

#include <cstring>

#include <utility>

#include "chungs/common/error.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda {

namespace {
void check(cudaError_t e, const char* op, const char* what, size_t bytes) {
  if (e != cudaSuccess) fail("CUDA ", op, " (", what, ", ", bytes, " bytes): ", cudaGetErrorString(e));
}
}  // namespace

DeviceBytes::~DeviceBytes() { release(); }

DeviceBytes::DeviceBytes(DeviceBytes&& o) noexcept
    : ptr_(std::exchange(o.ptr_, nullptr)), capacity_(std::exchange(o.capacity_, 0)) {}

DeviceBytes& DeviceBytes::operator=(DeviceBytes&& o) noexcept {
  if (this != &o) {
    release();
    ptr_ = std::exchange(o.ptr_, nullptr);
    capacity_ = std::exchange(o.capacity_, 0);
  }
  return *this;
}

void DeviceBytes::reserve(size_t bytes) {
  if (bytes <= capacity_) return;
  release();
  // Grow with headroom so that a slowly rising count (tile pairs, visible Gaussians) does not
  // reallocate every frame.
  const size_t want = bytes + bytes / 4;
  check(cudaMalloc(&ptr_, want), "cudaMalloc", "device buffer", want);
  capacity_ = want;
}

void DeviceBytes::release() {
  if (ptr_) cudaFree(ptr_);
  ptr_ = nullptr;
  capacity_ = 0;
}

void copy_to_device(void* dst, const void* src, size_t bytes, const char* what) {
  if (bytes == 0) return;
  check(cudaMemcpy(dst, src, bytes, cudaMemcpyHostToDevice), "copy to device", what, bytes);
}

void copy_to_host(void* dst, const void* src, size_t bytes, const char* what) {
  if (bytes == 0) return;
  check(cudaMemcpy(dst, src, bytes, cudaMemcpyDeviceToHost), "copy to host", what, bytes);
}

void fill_device_bytes(void* dst, int byte, size_t bytes, const char* what) {
  if (bytes == 0) return;
  check(cudaMemset(dst, byte, bytes), "memset", what, bytes);
}

void check_last(const char* what) { check(cudaGetLastError(), "launch", what, 0); }

void synchronize(const char* what) { check(cudaDeviceSynchronize(), "synchronize", what, 0); }

EventTimer::EventTimer() {
  cudaEvent_t a, b;
  check(cudaEventCreate(&a), "cudaEventCreate", "timer", 0);
  check(cudaEventCreate(&b), "cudaEventCreate", "timer", 0);
  begin_ = a, end_ = b;
}

EventTimer::~EventTimer() {
  cudaEventDestroy(static_cast<cudaEvent_t>(begin_));
  cudaEventDestroy(static_cast<cudaEvent_t>(end_));
}

void EventTimer::start() {
  check(cudaEventRecord(static_cast<cudaEvent_t>(begin_)), "event record", "timer", 0);
}

double EventTimer::stop_ms() {
  auto e = static_cast<cudaEvent_t>(end_);
  check(cudaEventRecord(e), "event record", "timer", 0);
  check(cudaEventSynchronize(e), "event synchronize", "timer", 0);
  float ms = 0;
  check(cudaEventElapsedTime(&ms, static_cast<cudaEvent_t>(begin_), e), "event elapsed", "timer", 0);
  return ms;
}

StagedUpload::StagedUpload() {
  cudaStream_t st;
  check(cudaStreamCreateWithFlags(&st, cudaStreamNonBlocking), "cudaStreamCreate", "staged upload", 0);
  stream_ = st;
  for (void** e : {&copied_[0], &copied_[1], &released_[0], &released_[1]}) {
    cudaEvent_t ev;
    check(cudaEventCreateWithFlags(&ev, cudaEventDisableTiming), "cudaEventCreate", "staged upload", 0);
    *e = ev;
  }
}

StagedUpload::~StagedUpload() {
  cudaStreamSynchronize(static_cast<cudaStream_t>(stream_));
  for (void* e : {copied_[0], copied_[1], released_[0], released_[1]}) cudaEventDestroy(static_cast<cudaEvent_t>(e));
  for (void* h : host_)
    if (h) cudaFreeHost(h);
  cudaStreamDestroy(static_cast<cudaStream_t>(stream_));
}

void StagedUpload::reserve_host(int b, size_t bytes, const char* what) {
  // Its last copy has left staging b.
  check(cudaEventSynchronize(static_cast<cudaEvent_t>(copied_[b])), "staging wait", what, bytes);
  if (bytes > host_capacity_[b]) {
    if (host_[b]) check(cudaFreeHost(host_[b]), "cudaFreeHost", what, host_capacity_[b]);
    host_[b] = nullptr, host_capacity_[b] = 0;
    const size_t want = bytes + bytes / 4;  // room for a list that grows a little
    check(cudaMallocHost(&host_[b], want), "cudaMallocHost", what, want);
    host_capacity_[b] = want;
  }
}

void* StagedUpload::next_host_buffer(size_t bytes, const char* what) {
  reserve_host(current_ ^ 1, bytes, what);
  return host_[current_ ^ 1];
}

const void* StagedUpload::upload(const void* src, size_t bytes, const char* what) {
  const int b = current_ ^ 1;
  auto* st = static_cast<cudaStream_t>(stream_);
  auto copied = static_cast<cudaEvent_t>(copied_[b]);
  if (bytes > 0 && src == host_[current_])
    fail("staged upload of ", what, ": internal error: the source was written into staging before another upload");
  if (bytes > 0 && src == host_[b] && bytes > host_capacity_[b])
    fail("staged upload of ", what, ": internal error: ", bytes, " bytes in a staging buffer of ", host_capacity_[b]);
  // Every use of the current buffer is queued on the default stream by now.
  check(cudaEventRecord(static_cast<cudaEvent_t>(released_[current_]), 0), "event record", what, 0);
  current_ = b;
  if (bytes == 0) return nullptr;
  reserve_host(b, bytes, what);
  device_[b].reserve(bytes);  // a reallocation frees the old memory only once the device is idle
  if (src != host_[b]) std::memcpy(host_[b], src, bytes);
  check(cudaStreamWaitEvent(st, static_cast<cudaEvent_t>(released_[b]), 0), "stream wait", what, 0);
  check(cudaMemcpyAsync(device_[b].data(), host_[b], bytes, cudaMemcpyHostToDevice, st), "copy to device", what,
        bytes);
  check(cudaEventRecord(copied, st), "event record", what, 0);
  check(cudaStreamWaitEvent(0, copied, 0), "stream wait", what, 0);
  return device_[b].data();
}

BoundaryEvents::BoundaryEvents(int count) {
  for (int i = 0; i < count; ++i) {
    cudaEvent_t e;
    check(cudaEventCreate(&e), "cudaEventCreate", "phase boundaries", 0);
    events_.push_back(e);
  }
}

BoundaryEvents::~BoundaryEvents() {
  for (void* e : events_) cudaEventDestroy(static_cast<cudaEvent_t>(e));
}

void BoundaryEvents::record(int i) {
  check(cudaEventRecord(static_cast<cudaEvent_t>(events_.at(size_t(i)))), "event record", "phase boundary", 0);
}

double BoundaryEvents::elapsed_ms(int a, int b) {
  auto eb = static_cast<cudaEvent_t>(events_.at(size_t(b)));
  check(cudaEventSynchronize(eb), "event synchronize", "phase boundary", 0);
  float ms = 0;
  check(cudaEventElapsedTime(&ms, static_cast<cudaEvent_t>(events_.at(size_t(a))), eb), "event elapsed",
        "phase boundary", 0);
  return ms;
}

}  // namespace chungs::cuda
