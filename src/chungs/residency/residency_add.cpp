// Residency: new Gaussians into the pool (residency.hpp, add and add_many).
#include <algorithm>
#include <unordered_set>
#include <utility>

#include "chungs/common/error.hpp"
#include "chungs/residency/residency.hpp"

namespace chungs {

PinResult Residency::add(ChunkId id, const GaussianBlock& block) {
  const ChunkAddition one[] = {{id, &block}};
  return add_many(one).front();
}

std::vector<PinResult> Residency::add_many(std::span<const ChunkAddition> adds) {
  std::vector<PinResult> results(adds.size());
  for (PinResult& r : results) r.budget = budget_, r.pinned_gaussians = pinned_gaussians_;
  std::vector<size_t> todo;  // the additions with Gaussians, all checked before anything changes
  for (size_t i = 0; i < adds.size(); ++i) {
    if (!adds[i].block) fail("residency: add_many entry ", i, " has no block");
    if (adds[i].block->size() == 0) continue;
    adds[i].block->validate("residency add");
    todo.push_back(i);
  }
  if (todo.empty()) return results;

  // The least they need resident together: everything pinned, their chunks, and the new Gaussians.
  std::unordered_set<ChunkId> seen;
  std::vector<ChunkId> ids, absent;  // each chunk once, in the order first named; those not resident
  std::vector<size_t> absent_at;     // the addition that first names each absent chunk
  uint64_t floor = pinned_gaussians_, extra = 0, fresh = 0;
  for (size_t i : todo) {
    const ChunkId id = adds[i].id;
    const uint64_t n = adds[i].block->size();
    if (seen.insert(id).second) {
      ids.push_back(id);
      floor += is_pinned(id) ? 0 : count(id);
      if (!is_resident(id)) {
        extra += count(id);
        absent.push_back(id);
        absent_at.push_back(i);
      }
    }
    floor += n, extra += n, fresh += n;
  }
  if (todo.size() == 1 && floor > budget_) {
    const size_t i = todo.front();
    const ChunkId id = adds[i].id;
    PinResult& r = results[i];
    r.ok = false;
    r.over_budget = floor - budget_;
    r.message = cat("residency: adding ", adds[i].block->size(), " Gaussians to ", chunk_name(id), " (", count(id),
                    " already) beside ", pinned_gaussians_, " pinned ones would exceed the budget of ", budget_,
                    " by ", r.over_budget, "; nothing was added.");
    return results;
  }
  // Together they do not fit: one at a time, each refused or kept on its own as add() would, the later
  // ones free to evict the earlier.
  if (floor > budget_) {
    for (size_t i : todo) results[i] = add_many(adds.subspan(i, 1)).front();
    return results;
  }

  // One eviction pass, one read of the absent chunks and one upload for all of them: on a GPU one
  // round trip per keyframe instead of one per chunk it adds to.
  if (!make_room(extra, ids, &results[todo.front()].evicted))
    fail("residency: internal error: no room for ", extra, " Gaussians although they fit the budget");
  // make_room keeps `ids`, so what was absent above still is.
  for (ChunkId id : ids)
    if (!contains(id)) {
      catalogue_[id] = 0;
      ++catalogue_version_;
    }
  load_many(absent);
  for (size_t i : absent_at) results[i].loaded = 1;
  copy_out_many(ids);
  std::vector<ConstBlockArrays> arrays;
  for (size_t i : todo) arrays.push_back(block_arrays(*adds[i].block));
  std::vector<uint32_t> slots = pool_.allocate(fresh);
  try {
    pool_.scatter(arrays, slots);
  } catch (...) {
    pool_.release(slots);
    throw;
  }
  size_t first = 0;
  for (size_t i : todo) {
    const ChunkId id = adds[i].id;
    const size_t n = adds[i].block->size();
    Resident& e = resident_.at(id);
    e.slots.insert(e.slots.end(), slots.begin() + std::ptrdiff_t(first), slots.begin() + std::ptrdiff_t(first + n));
    first += n;
    e.dirty = true;
    checkpoint_clean_.erase(id);
    touch(e, id);
    resident_gaussians_ += n;
    catalogue_[id] += n;
    if (e.pins > 0) pinned_gaussians_ += n;
  }
  peak_resident_ = std::max(peak_resident_, resident_gaussians_);
  for (PinResult& r : results) r.pinned_gaussians = pinned_gaussians_;
  check_budget_invariant();
  return results;
}

}  // namespace chungs
