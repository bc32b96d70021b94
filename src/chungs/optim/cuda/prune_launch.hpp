// Internal: the device pruning rule's launches with plain C++17 arguments, so that prune.cu need not
// see chungs/optim/prune.hpp (C++20, while .cu files compile as C++17).
#pragma once
#include <cstddef>
#include <cstdint>

namespace chungs::cuda::detail {

struct PruneLaunch {
  const float* opacity;  // logits by slot
  uint32_t capacity;
  const uint32_t* ids;   // the view's slots
  uint32_t n;
  const float* radius;   // per view entry, or null: no size test
  float max_radius, min_logit;
  const uint32_t* visits;  // by slot, or null: no age test
  uint32_t min_visits;
  const uint32_t* places;  // n: what to report for entry j
  uint8_t* flags;      // n
  uint32_t* selected;  // n
  uint32_t* count;     // 1
};

// Scratch bytes the compaction of n entries needs.
size_t prune_temp_bytes(uint32_t n);
// Flags the entries and compacts the flagged ones' places, in the order of ids, into selected; returns their
// count
// (waits for the device). temp holds prune_temp_bytes(n).
uint32_t launch_prune_select(const PruneLaunch& a, void* temp, size_t temp_bytes);

}  // namespace chungs::cuda::detail
