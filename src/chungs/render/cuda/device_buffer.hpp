// Owning device-memory buffers with host<->device copies, usable from plain C++ files (no CUDA
// headers here: the calls live in device_buffer.cu). Every CUDA error becomes a chungs::Error that
// names the operation and the size.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace chungs::cuda {

// Raw allocation (cudaMalloc); grows on demand and keeps its memory when shrinking.
class DeviceBytes {
 public:
  DeviceBytes() = default;
  explicit DeviceBytes(size_t bytes) { reserve(bytes); }
  ~DeviceBytes();
  DeviceBytes(const DeviceBytes&) = delete;
  DeviceBytes& operator=(const DeviceBytes&) = delete;
  DeviceBytes(DeviceBytes&& o) noexcept;
  DeviceBytes& operator=(DeviceBytes&& o) noexcept;

  // Makes room for `bytes`; old contents are lost when it has to reallocate.
  void reserve(size_t bytes);
  void release();
  void* data() const { return ptr_; }
  size_t capacity() const { return capacity_; }

 private:
  void* ptr_ = nullptr;
  size_t capacity_ = 0;
};

// Synchronous copies (they wait for the device); `what` names the buffer in error messages.
void copy_to_device(void* dst, const void* src, size_t bytes, const char* what);
void copy_to_host(void* dst, const void* src, size_t bytes, const char* what);
void fill_device_bytes(void* dst, int byte, size_t bytes, const char* what);
// Throws Error naming `what` when the last launch or the device failed.
void check_last(const char* what);
void synchronize(const char* what);

// Device time between start() and stop_ms() on the default stream, from CUDA events.
class EventTimer {
 public:
  EventTimer();
  ~EventTimer();
  EventTimer(const EventTimer&) = delete;
  EventTimer& operator=(const EventTimer&) = delete;
  void start();
  double stop_ms();  // waits for the work recorded since start()

 private:
  void* begin_ = nullptr;
  void* end_ = nullptr;
};

// Host-to-device copies that neither hold the host nor take the default stream's time: the data is
// copied into one of two pinned staging buffers and from there, on a copy stream of its own, into one
// of two device buffers, which the default stream waits for. So the copy of the next step's list runs
// while the default stream still works on the current one (which reads the other buffer). A buffer is
// written again only after the default stream has passed every use queued before the upload that
// switched away from it. A plain copy from pageable memory waits for all work queued before it (a
// 1 M slot list: 0.35 ms of every step); one on the default stream adds its transfer to the step.
class StagedUpload {
 public:
  StagedUpload();
  ~StagedUpload();
  StagedUpload(const StagedUpload&) = delete;
  StagedUpload& operator=(const StagedUpload&) = delete;
  // Device copy of src, valid for the work queued on the default stream until the next upload but one.
  const void* upload(const void* src, size_t bytes, const char* what);
  // The pinned buffer the next upload copies from, room for `bytes`, once its last copy has left it.
  // Data written there and passed to that upload goes up without the host copy (a 190 k slot list
  // took 0.09 ms of the host's step, a 830 k one 0.5 ms). Another upload in between would overwrite
  // it: upload() refuses a source in the other staging buffer.
  void* next_host_buffer(size_t bytes, const char* what);

 private:
  void reserve_host(int b, size_t bytes, const char* what);
  void* stream_ = nullptr;
  void* host_[2] = {nullptr, nullptr};  // pinned
  size_t host_capacity_[2] = {0, 0};
  DeviceBytes device_[2];
  void* copied_[2] = {nullptr, nullptr};    // on the copy stream, after the buffer's copy
  void* released_[2] = {nullptr, nullptr};  // on the default stream, after the buffer's last use
  int current_ = 0;
};

// CUDA events at numbered boundaries on the default stream (a step's phases): record(i) marks
// boundary i after the work launched so far; elapsed_ms(a, b) waits for boundary b.
class BoundaryEvents {
 public:
  explicit BoundaryEvents(int count);
  ~BoundaryEvents();
  BoundaryEvents(const BoundaryEvents&) = delete;
  BoundaryEvents& operator=(const BoundaryEvents&) = delete;
  int count() const { return int(events_.size()); }
  void record(int i);
  double elapsed_ms(int a, int b);

 private:
  std::vector<void*> events_;
};

// A typed array of `size()` elements in device memory.
template <typename T>
class DeviceArray {
 public:
  DeviceArray() = default;
  explicit DeviceArray(size_t n) { resize(n); }
  explicit DeviceArray(const std::vector<T>& host) { upload(host); }

  void resize(size_t n) {
    bytes_.reserve(n * sizeof(T));
    size_ = n;
  }
  void upload(const T* host, size_t n) {
    resize(n);
    copy_to_device(bytes_.data(), host, n * sizeof(T), "DeviceArray::upload");
  }
  void upload(const std::vector<T>& host) { upload(host.data(), host.size()); }
  void download(std::vector<T>& host) const {
    host.resize(size_);
    copy_to_host(host.data(), bytes_.data(), size_ * sizeof(T), "DeviceArray::download");
  }
  std::vector<T> download() const {
    std::vector<T> h;
    download(h);
    return h;
  }
  void fill_bytes(int byte) {
    fill_device_bytes(bytes_.data(), byte, size_ * sizeof(T), "DeviceArray::fill");
  }

  T* data() { return static_cast<T*>(bytes_.data()); }
  const T* data() const { return static_cast<const T*>(bytes_.data()); }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

 private:
  DeviceBytes bytes_;
  size_t size_ = 0;
};

}  // namespace chungs::cuda
