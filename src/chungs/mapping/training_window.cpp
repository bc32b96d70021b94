#include "chungs/mapping/training_window.hpp"

#include <algorithm>
#include <unordered_set>

namespace chungs {

std::vector<uint32_t> fit_training_window(std::vector<WindowKeyframe> keyframes,
                                          const std::function<uint64_t(ChunkId)>& count, uint64_t room) {
  std::sort(keyframes.begin(), keyframes.end(), [](const WindowKeyframe& a, const WindowKeyframe& b) {
    return a.distance != b.distance ? a.distance < b.distance : a.id < b.id;
  });
  std::vector<uint32_t> out;
  std::unordered_set<ChunkId> seen;
  uint64_t total = 0;
  for (const WindowKeyframe& k : keyframes) {
    uint64_t more = 0;
    if (k.chunks)
      for (ChunkId c : *k.chunks)
        if (seen.insert(c).second) more += count(c);
    // The window stays a ball around the latest keyframe: a farther keyframe that would still fit
    // is not taken once a nearer one did not.
    if (!out.empty() && total + more > room) break;
    total += more;
    out.push_back(k.id);
  }
  return out;
}

}  // namespace chungs
