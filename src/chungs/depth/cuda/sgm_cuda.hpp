// The GPU twin of sgm_disparities (depth/sgm.hpp): the same census, paths, winners and right-view
// winners, bit for bit. At KITTI's full resolution a few milliseconds where the CPU took 50-250 ms,
// which was what a keyframe's load under real-time pacing waited for. Safe to call from several
// threads (they take turns on one device workspace and stream); the stream does not wait for the
// default stream's work, so the optimiser's steps keep running beside it.
#pragma once
#include "chungs/depth/sgm.hpp"

namespace chungs::cuda {

SgmDisparities sgm_disparities(const Image8& left, const Image8& right, const SgmParams& params);

}  // namespace chungs::cuda
