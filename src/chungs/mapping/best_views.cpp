#include "chungs/mapping/best_views.hpp"

#include <algorithm>

namespace chungs {

void BestViews::note(uint32_t keyframe, const ViewCoverage& coverage) {
  const std::vector<uint32_t>& blocks = coverage.blocks_per_chunk();
  for (size_t i = 0; i < blocks.size(); ++i) {
    Best& b = best_[coverage.chunks()[i]];
    if (blocks[i] > b.blocks) b = {blocks[i], keyframe};
  }
}

std::vector<ChunkId> BestViews::shown_better(uint32_t keyframe, const ViewCoverage& coverage, double share,
                                             const std::function<bool(uint32_t)>& in_window) const {
  std::vector<ChunkId> out;
  const std::vector<uint32_t>& blocks = coverage.blocks_per_chunk();
  for (size_t i = 0; i < blocks.size(); ++i) {
    const auto it = best_.find(coverage.chunks()[i]);
    if (it == best_.end() || it->second.keyframe == keyframe) continue;
    if (double(blocks[i]) < share * double(it->second.blocks) && !in_window(it->second.keyframe))
      out.push_back(coverage.chunks()[i]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace chungs
