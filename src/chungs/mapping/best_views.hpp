// Which chunks a view must leave alone under a training window. A place is held in shape by the
// views that showed it largest; once they leave the window, later views that glimpse it from afar or
// at a grazing angle (after a turn, or from a parallel street) reshape it with nothing to pull it
// back, and the views that saw it head-on score it worse at the end (measured: -10 dB on a stretch
// of an 800 m street under a 25 k budget, smeared sky and opaque blobs metres wide). So each chunk
// remembers its best view, and a step on a view that shows it on under `share` of that view's blocks
// does not score its pixels while the best view is outside the window. Nor does the sampler add to
// them from that view, whether or not the best view is still trained: a far view's sky pixels, sampled
// at the fill depth, had put opaque blobs metres wide on a street mapped long before, and without a
// budget far views hazed a street no later view came near.
#pragma once
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "chungs/mapping/view_coverage.hpp"
#include "chungs/store/chunk_id.hpp"

namespace chungs {

class BestViews {
 public:
  // A keyframe's view (its coverage) becomes the best view of the chunks it shows on more blocks
  // than their best view so far (ties: the earlier keyframe stays).
  void note(uint32_t keyframe, const ViewCoverage& coverage);
  // The chunks of `keyframe`'s view shown on fewer than `share` of the blocks their best view
  // showed them on, whose best view is another keyframe and not `in_window`; sorted.
  std::vector<ChunkId> shown_better(uint32_t keyframe, const ViewCoverage& coverage, double share,
                                    const std::function<bool(uint32_t)>& in_window) const;
  size_t chunks() const { return best_.size(); }
  void clear() { best_.clear(); }

 private:
  struct Best {
    uint32_t blocks = 0, keyframe = 0;
  };
  std::unordered_map<ChunkId, Best> best_;
};

}  // namespace chungs
