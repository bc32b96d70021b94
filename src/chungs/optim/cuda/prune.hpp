// The pruning rule on the GPU: chungs::select_for_pruning (its CPU twin) from device arrays, the same
// places in the view in the same order; only the selected places come back to the host. Copying every opacity
// of the pool to the host each pruning step (6-12 MB at 1.5-3 M slots) had cost 1.4-3.4 ms of it. Include
// only from C++ files: no CUDA headers here.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "chungs/optim/prune.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda {

class CudaPruneSelector {
 public:
  // opacity: logits by pool slot (device, `capacity` of them); ids: the n slots of the view (device);
  // radius: their screen radii from the last render (device, n) or null to skip the size test;
  // visits: optimiser steps by pool slot (device, capacity) or null, read when config.min_visits > 0.
  // places: where each entry of ids stands in the caller's list (device, n; e.g. SlotOrder's). `out`
  // receives the selected entries' places in the caller's list, ascending.
  // Slots out of range are never selected (the rasterizer refuses them first).
  void select(const PruneConfig& config, const float* opacity, size_t capacity, const uint32_t* ids, size_t n,
              const float* radius, int image_width, const uint32_t* visits, const uint32_t* places,
              std::vector<uint32_t>& out);

 private:
  DeviceArray<uint8_t> flags_;
  DeviceArray<uint32_t> selected_, count_;
  DeviceBytes temp_;
};

}  // namespace chungs::cuda
