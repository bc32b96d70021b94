// New chunks' sampled Gaussians too few to make a chunk file of their own, held until later
// keyframes add enough in the same chunk.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "chungs/mapping/sampler.hpp"

namespace chungs {

class StrayPool {
 public:
  // Adds keyframe `keyframe`'s held-back batches, takes out the chunks whose Gaussians now number at
  // least `least` or that `exists` (the map made them meanwhile), and forgets chunks that got none in
  // the last `wait` keyframes. The Gaussians taken out count as created at `step`: their training
  // starts there.
  std::vector<ChunkBatch> add(uint32_t keyframe, std::vector<ChunkBatch> strays, uint64_t least, int wait,
                              uint32_t step, const std::function<bool(ChunkId)>& exists);
  void forget_all();  // counted as forgotten
  size_t chunks() const { return entries_.size(); }
  uint64_t gaussians() const;
  uint64_t forgotten() const { return forgotten_; }  // Gaussians dropped after waiting in vain

 private:
  struct Entry {
    GaussianBlock block;
    uint32_t last_keyframe = 0;
  };
  std::map<ChunkId, Entry> entries_;
  uint64_t forgotten_ = 0;
};

}  // namespace chungs
