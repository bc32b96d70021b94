// The step's slot list in slot order, for the kernels that read the pool by slot. A grown map's chunks
// hold slots scattered over the pool (pruning's holes are reused by new Gaussians), and the pool's small
// arrays (mean, scale, rotation, opacity and their Adam moments: 4-16 bytes a Gaussian each) then cost a
// 32-byte sector per list entry: on a grown ~1 M street Adam took 0.86 ms a step where the same map
// resumed from disk, each chunk in a run of slots, took 0.36 ms. In slot order, neighbouring entries read
// neighbouring memory. The order does not change a step's arithmetic (Adam works per Gaussian, the
// rasterizer sorts by depth) except which of two equally deep splats composites first.
// No CUDA headers here (the sort lives in slot_order.cu).
#pragma once
#include <cstddef>
#include <cstdint>

#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda {

class SlotOrder {
 public:
  // Sorts the n slots of `ids` (device) ascending on the bits a slot below `capacity` has, keeping each
  // one's place in ids. A slot at or past capacity keeps its value (the rasterizer refuses it) but not
  // its rank. Default stream; does not wait.
  void sort(const uint32_t* ids, size_t n, size_t capacity);
  const uint32_t* ids() const { return sorted_.data(); }     // n slots, ascending
  const uint32_t* places() const { return places_.data(); }  // places()[i]: where ids()[i] stood

 private:
  DeviceArray<uint32_t> sorted_, places_, sequence_;  // sequence_: 0, 1, 2, ... (the places' source)
  size_t sequence_n_ = 0;
  DeviceBytes temp_;
};

}  // namespace chungs::cuda
