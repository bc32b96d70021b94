// The training window: which keyframes of the selector's cell the optimiser may train on so that
// the chunks they see fit the memory budget together. Without it, a budget smaller than the cell's
// map makes consecutive steps need different chunks, and most of the step time goes to loading
// and evicting them (measured: 49 % I/O wait at a 100 000 budget on a 2 km street).
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "chungs/store/chunk_id.hpp"

namespace chungs {

struct WindowKeyframe {
  uint32_t id = 0;
  double distance = 0;                          // from the latest keyframe
  const std::vector<ChunkId>* chunks = nullptr;  // the chunks its view needs
};

// Keyframes nearest first, as long as the union of their chunks holds at most `room` Gaussians
// (`count` gives a chunk's); the nearest is always in. Ties in distance go to the lower id.
// Returned nearest first.
std::vector<uint32_t> fit_training_window(std::vector<WindowKeyframe> keyframes,
                                          const std::function<uint64_t(ChunkId)>& count, uint64_t room);

}  // namespace chungs
