// Where the run hands one camera's multiview depth to the mapper beyond a keyframe's own: the depth
// a keyframe's load computed for earlier keyframes, and the report of both sides.
#pragma once
#include <cstddef>
#include <nlohmann/json.hpp>

#include "chungs/mapping/mapper.hpp"
#include "chungs/pipeline/frame_source.hpp"
#include "chungs/pipeline/multiview_keyframes.hpp"

namespace chungs {

// Before keyframe `frame` (whose load produced m) is added: the deferred keyframes' first depth
// (Mapper::add_late_depth; m.median_depth takes theirs when m has none) and the earlier keyframes'
// guesses made again (Mapper::redepth). Keyframes the run dropped (real-time pacing) are skipped.
void give_earlier_keyframes_depth(Mapper& mapper, MappingFrame& m, size_t frame);

// MultiviewKeyframes::report() with the mapper's redepth totals under "redepth".
nlohmann::json multiview_report(const MultiviewKeyframes& multiview, const Mapper& mapper);

}  // namespace chungs
