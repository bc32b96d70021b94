// A keyframe depth that places Gaussians but is no measurement (one camera's membrane fill, with
// multiview.supervise_fill off) is stored negated. Whatever places Gaussians or locates surfaces
// (the sampler, the partial views' coverage) reads its magnitude; the depth loss, which scores
// positive depth only, leaves it out. The keyframe file keeps the sign, so a resumed map does too.
#pragma once
#include <cmath>

namespace chungs {

inline float guessed_depth(float z) { return -z; }
// The depth to place at: a guess's magnitude, anything else as it is.
inline float placement_depth(float z) { return z < 0 && std::isfinite(z) ? -z : z; }

}  // namespace chungs
