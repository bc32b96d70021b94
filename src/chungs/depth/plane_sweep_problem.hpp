// The plane sweep's inputs checked and turned into the float images and per-neighbour homographies
// that sweep_pixel reads: shared by the CPU loops and the CUDA upload so both start from the same bits.
#pragma once
#include <vector>

#include "chungs/depth/plane_sweep.hpp"
#include "chungs/depth/plane_sweep_core.hpp"

namespace chungs {

struct PreparedSweep {
  PreparedSweep() = default;
  PreparedSweep(PreparedSweep&&) = default;  // a move keeps the vectors' buffers, so the pointers hold
  PreparedSweep(const PreparedSweep&) = delete;  // a copy would point into the original
  PreparedSweep& operator=(const PreparedSweep&) = delete;
  plane_sweep::Problem problem;  // image pointers point into the vectors below
  std::vector<float> ref;
  std::vector<std::vector<float>> neighbours;
  std::vector<float> prior_inv, prior_conf;  // empty without a prior
};

PreparedSweep prepare_sweep(const PlaneSweepInput& input, const PlaneSweepConfig& config);
void check_sweep_pixels(const PreparedSweep& s, const std::vector<SweepPixel>& pixels);

}  // namespace chungs
