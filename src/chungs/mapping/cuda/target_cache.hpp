// Step targets kept in VRAM. Each keyframe's stored images (8-bit colour, float depth) go up once
// and stay while they fit the cache's bytes, least recently used dropped first; every step expands
// them into the float targets the loss reads with one kernel, with the arithmetic of host_targets
// (its CPU twin). Before, every step converted the images on the host and uploaded them: ~9 MB a
// step at KITTI's full resolution. No CUDA headers here (the kernel lives in target_cache.cu).
#pragma once
#include <cstddef>
#include <cstdint>
#include <list>
#include <unordered_map>

#include "chungs/mapping/step_targets.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda {

namespace detail {
// rgb[3i+k] = color[C*i + min(k, C-1)] / 255; where depth is given and depth[i] is finite and > 0:
// inv[i] = 1 / depth[i], mask[i] = 1, else 0 and 0. Default stream, does not wait.
void launch_expand_targets(const uint8_t* color, int channels, const float* depth, size_t pixels, float* rgb,
                           float* inv, uint8_t* mask);
}  // namespace detail

struct DeviceTargets {
  int width = 0, height = 0;
  bool depth = false;  // inv_depth and mask hold a depth term
};

class DeviceTargetCache {
 public:
  // At most `capacity_bytes` and `max_entries` keyframes.
  explicit DeviceTargetCache(size_t capacity_bytes, size_t max_entries = SIZE_MAX)
      : capacity_(capacity_bytes), max_entries_(max_entries) {}
  // The float targets of `targets` in rgb (3 channels), inv_depth and mask (device, resized).
  DeviceTargets expand(const StepTargets& targets, DeviceArray<float>& rgb, DeviceArray<float>& inv_depth,
                       DeviceArray<uint8_t>& mask);
  size_t bytes() const { return bytes_; }
  size_t entries() const { return entries_.size(); }
  uint64_t uploads() const { return uploads_; }  // keyframes sent to the device

 private:
  struct Entry {
    DeviceArray<uint8_t> color;
    DeviceArray<float> depth;  // empty without depth
    int width = 0, height = 0, channels = 0;
    size_t bytes = 0;
    std::list<uint64_t>::iterator lru;
  };
  Entry& upload(const KeyframeImages& images, Entry& e);

  size_t capacity_, max_entries_, bytes_ = 0;
  uint64_t uploads_ = 0;
  std::unordered_map<uint64_t, Entry> entries_;
  std::list<uint64_t> lru_;  // most recent first
  Entry scratch_;            // targets not kept (key 0, or larger than the cache)
};

}  // namespace chungs::cuda
