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
  cudaEvent_t e;
  check(cudaEventCreateWithFlags(&e, cudaEventDisableTiming), "cudaEventCreate", "staged upload", 0);
  done_ = e;
}

StagedUpload::~StagedUpload() {
  if (done_) {
    cudaEventSynchronize(static_cast<cudaEvent_t>(done_));
    cudaEventDestroy(static_cast<cudaEvent_t>(done_));
  }
  if (host_) cudaFreeHost(host_);
}

void StagedUpload::upload(void* dst, const void* src, size_t bytes, const char* what) {
  if (bytes == 0) return;
  check(cudaEventSynchronize(static_cast<cudaEvent_t>(done_)), "staging wait", what, bytes);
  if (bytes > capacity_) {
    if (host_) check(cudaFreeHost(host_), "cudaFreeHost", what, capacity_);
    host_ = nullptr, capacity_ = 0;
    const size_t want = bytes + bytes / 4;  // room for a list that grows a little
    check(cudaMallocHost(&host_, want), "cudaMallocHost", what, want);
    capacity_ = want;
  }
  std::memcpy(host_, src, bytes);
  check(cudaMemcpyAsync(dst, host_, bytes, cudaMemcpyHostToDevice, 0), "copy to device", what, bytes);
  check(cudaEventRecord(static_cast<cudaEvent_t>(done_), 0), "event record", what, 0);
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
