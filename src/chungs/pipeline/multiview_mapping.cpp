#include "chungs/pipeline/multiview_mapping.hpp"

#include <algorithm>

#include "chungs/common/log.hpp"

namespace chungs {

void give_earlier_keyframes_depth(Mapper& mapper, MappingFrame& m, size_t frame) {
  const auto kept = [&](size_t f) {
    const auto& kfs = mapper.keyframes();
    return std::any_of(kfs.begin(), kfs.end(), [&](const auto& k) { return k.frame == f; });
  };
  // The deferred ones first: they are older.
  for (const auto& [earlier, depth] : m.late_depth) {
    if (!kept(earlier)) continue;
    const SampleStats ls = mapper.add_late_depth(earlier, depth);
    if (!(m.median_depth > 0)) m.median_depth = median_valid_depth(depth);
    log::debug("frame ", earlier, ": ", ls.kept, " new Gaussians from depth computed with frame ", frame);
  }
  for (const auto& [earlier, depth] : m.refresh_depth)
    if (kept(earlier)) mapper.redepth(earlier, depth);
}

nlohmann::json multiview_report(const MultiviewKeyframes& multiview, const Mapper& mapper) {
  nlohmann::json j = multiview.report();
  const Mapper::RedepthTotals& rt = mapper.redepth_totals();
  j["redepth"] = {{"keyframes", rt.keyframes}, {"pixels", rt.pixels}, {"gaussians_moved", rt.gaussians_moved}};
  return j;
}

}  // namespace chungs
