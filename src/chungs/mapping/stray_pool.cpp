#include "chungs/mapping/stray_pool.hpp"

#include <algorithm>

namespace chungs {

std::vector<ChunkBatch> StrayPool::add(uint32_t keyframe, std::vector<ChunkBatch> strays, uint64_t least, int wait,
                                       uint32_t step, const std::function<bool(ChunkId)>& exists) {
  for (ChunkBatch& b : strays) {
    Entry& e = entries_[b.id];
    if (e.block.size() == 0)
      e.block = std::move(b.block);
    else
      e.block.append_range(b.block, 0, b.block.size());
    e.last_keyframe = keyframe;
  }
  std::vector<ChunkBatch> out;
  for (auto it = entries_.begin(); it != entries_.end();) {
    Entry& e = it->second;
    const uint64_t n = e.block.size();
    if (n >= least || (exists && exists(it->first))) {
      std::fill(e.block.created_at_step.begin(), e.block.created_at_step.end(), step);
      out.push_back({it->first, std::move(e.block)});
      it = entries_.erase(it);
    } else if (keyframe >= e.last_keyframe + uint32_t(std::max(wait, 0))) {
      forgotten_ += n;
      it = entries_.erase(it);
    } else {
      ++it;
    }
  }
  return out;
}

void StrayPool::forget_all() {
  forgotten_ += gaussians();
  entries_.clear();
}

uint64_t StrayPool::gaussians() const {
  uint64_t n = 0;
  for (const auto& [id, e] : entries_) n += e.block.size();
  return n;
}

}  // namespace chungs
