#include "chungs/mapping/refinement_plan.hpp"

#include <unordered_set>

#include "chungs/common/error.hpp"

namespace chungs {

std::vector<RefinementGroup> plan_refinement(const std::vector<std::vector<ChunkCount>>& views, uint64_t fit,
                                             uint64_t steps) {
  if (fit == 0) fail("refinement plan: the share of the budget a group may fill is 0");
  std::vector<RefinementGroup> groups;
  std::unordered_set<ChunkId> held;
  uint64_t sum = 0;
  for (size_t k = 0; k < views.size(); ++k) {
    uint64_t more = 0;
    for (const ChunkCount& c : views[k])
      if (!held.count(c.id)) more += c.count;
    if (groups.empty() || sum + more > fit) {
      groups.push_back({k, k, 0});
      held.clear();
      sum = 0;
    }
    for (const ChunkCount& c : views[k])
      if (held.insert(c.id).second) sum += c.count;
    groups.back().end = k + 1;
  }
  // 128-bit products: steps may be near 2^63 and K large.
  const unsigned __int128 total = views.size();
  const auto share_until = [&](size_t k) { return uint64_t((unsigned __int128)steps * k / total); };
  for (RefinementGroup& g : groups) g.steps = share_until(g.end) - share_until(g.begin);
  return groups;
}

}  // namespace chungs
