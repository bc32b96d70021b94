#include "chungs/residency/budget_groups.hpp"

#include <algorithm>
#include <utility>

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

std::vector<ChunkCount> nearest_first(std::span<const ChunkId> culled, const Residency& residency,
                                      double chunk_size, const Eigen::Vector3d& centre) {
  std::vector<std::pair<double, ChunkCount>> by_dist;
  for (ChunkId id : culled)
    if (const uint64_t n = residency.count(id))
      by_dist.push_back({(chunk_centre(chunk_coord(id), chunk_size) - centre).squaredNorm(), {id, n}});
  std::sort(by_dist.begin(), by_dist.end(), [](const auto& a, const auto& b) {
    return a.first < b.first || (a.first == b.first && a.second.id < b.second.id);
  });
  std::vector<ChunkCount> out;
  out.reserve(by_dist.size());
  for (const auto& [d, c] : by_dist) out.push_back(c);
  return out;
}

}  // namespace chungs
