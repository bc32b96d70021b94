#include "chungs/residency/budget_groups.hpp"

#include "chungs/common/error.hpp"

namespace chungs {

BudgetGroups split_by_budget(const std::vector<ChunkCount>& nearest_first, uint64_t budget) {
  if (budget == 0) fail("render passes: a budget of 0 Gaussians holds no chunk");
  BudgetGroups out;
  uint64_t in_group = 0;
  for (const ChunkCount& c : nearest_first) {
    if (c.count == 0) continue;
    if (c.count > budget) {
      out.too_large.push_back(c.id);
      continue;
    }
    if (out.groups.empty() || in_group + c.count > budget) {
      out.groups.emplace_back();
      in_group = 0;
    }
    out.groups.back().push_back(c.id);
    in_group += c.count;
  }
  return out;
}

}  // namespace chungs
