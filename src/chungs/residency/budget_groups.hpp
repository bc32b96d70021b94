// A view's chunks for drawing under the memory budget: nearest first, cut into groups that each fit
// (for rendering in passes, render/render_passes.hpp, when all of them do not fit at once), and
// their slots while they are pinned. Shared by the mapper's renders and MapRenderer.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/residency/residency.hpp"
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

// The culled chunks that hold Gaussians, by the distance of their centres from `centre`, nearest
// first (the budget then gives up the far field, which covers the fewest pixels), with their counts.
std::vector<ChunkCount> nearest_first(std::span<const ChunkId> culled, const Residency& residency,
                                      double chunk_size, const Eigen::Vector3d& centre);

// f(slots) over the slots of `chunks` while they are pinned, unpinning on every path; `who` starts
// the error when they cannot all be resident.
template <class F>
auto with_pinned_slots(Residency& residency, std::span<const ChunkId> chunks, std::vector<uint32_t>& slots,
                       const char* who, F&& f) {
  const PinResult pr = residency.pin(chunks);
  if (!pr.ok) fail(who, ": cannot make the visible chunks resident: ", pr.message);
  decltype(f(slots)) out;
  try {
    slots.clear();
    residency.append_slots(chunks, slots);
    out = f(slots);
  } catch (...) {
    residency.unpin(chunks);
    throw;
  }
  residency.unpin(chunks);
  return out;
}

}  // namespace chungs
