// Per-tile front-to-back alpha compositing and its backward. Inside a tile the loop runs splat by
// splat over the pixels of the splat's box, so each splat's data is loaded once per tile and its
// gradient is summed in registers before it is added to the per-thread buffer.
#pragma once
#include <cstdint>
#include <vector>

#include "chungs/render/cpu/binning.hpp"
#include "chungs/render/cpu/splat.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_output.hpp"

namespace chungs::cpu {

// Writes the images of `out` (already sized width x height) and, per pixel, how many entries of its
// tile's list were walked up to and including the last one that contributed (`last`), which the
// backward needs to stop where the forward stopped.
template <typename T>
void composite_forward(const std::vector<Splat<T>>& splats, const TileBins& bins, const uint32_t* ids,
                       const RasterConfig& cfg, RenderOutput<T>& out, std::vector<uint32_t>& last);

// Accumulates dLoss/d(splat quantities) into splat_grads (kSplatGrad per splat, overwritten).
// thread_buffers is scratch kept by the caller between calls.
template <typename T>
void composite_backward(const std::vector<Splat<T>>& splats, const TileBins& bins, const RasterConfig& cfg,
                        const RenderOutput<T>& out, const std::vector<uint32_t>& last,
                        const RenderGrads<T>& grads, std::vector<std::vector<T>>& thread_buffers,
                        std::vector<T>& splat_grads);

}  // namespace chungs::cpu
