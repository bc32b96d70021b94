// The GPU twin of plane_sweep_dense / plane_sweep_at (depth/plane_sweep.hpp): one thread per pixel
// runs the same sweep_pixel (plane_sweep_core.hpp) as the CPU loops, so the results are the same bit
// for bit. Safe to call from several threads: they take turns on one device workspace and stream.
#pragma once
#include <vector>

#include "chungs/depth/plane_sweep.hpp"

namespace chungs::cuda {

PlaneSweepDepth plane_sweep_dense(const PlaneSweepInput& input, const PlaneSweepConfig& config);
std::vector<SweepSample> plane_sweep_at(const PlaneSweepInput& input, const std::vector<SweepPixel>& pixels,
                                        const PlaneSweepConfig& config);

}  // namespace chungs::cuda
