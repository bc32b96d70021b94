// A view's chunks cut into groups that each fit the memory budget, for rendering it in passes
// (render/render_passes.hpp) when all of them do not fit at once.
#pragma once
#include <cstdint>
#include <vector>

#include "chungs/store/chunk_id.hpp"

namespace chungs {

struct ChunkCount {
  ChunkId id;
  uint64_t count;  // Gaussians
};

struct BudgetGroups {
  // Consecutive runs of the input, in its order, each holding at most the budget's Gaussians; a
  // group ends where the next chunk would not fit, so a later group never holds a nearer chunk.
  std::vector<std::vector<ChunkId>> groups;
  std::vector<ChunkId> too_large;  // chunks that alone hold more than the budget: drawn by no group
};

// `nearest_first`: the view's chunks ordered by distance from the camera. Chunks without Gaussians
// are left out. Throws Error when the budget is 0.
BudgetGroups split_by_budget(const std::vector<ChunkCount>& nearest_first, uint64_t budget);

}  // namespace chungs
