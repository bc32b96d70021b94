// Per-Gaussian stage of the rasterizer: EWA projection of the 3D covariance, SH colour along the
// viewing ray, opacity, footprint; and its backward from splat gradients to the parameters.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "chungs/render/cpu/splat.hpp"
#include "chungs/render/gaussian_view.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_camera.hpp"

namespace chungs::cpu {

// Fills splats[j] for Gaussian ids[j]; culled ones get an empty box. Parallel over Gaussians.
template <typename T>
void project_splats(const GaussianArrays<T>& g, const uint32_t* ids, size_t n, const RenderCamera<T>& cam,
                    const RasterConfig& cfg, std::vector<Splat<T>>& splats);

// Chains splat_grads (kSplatGrad per splat) back to the parameters of every visible splat; entries of
// culled splats are zero. Recomputes the forward intermediates instead of storing them.
template <typename T>
void backward_splats(const GaussianArrays<T>& g, const uint32_t* ids, size_t n, const RenderCamera<T>& cam,
                     const RasterConfig& cfg, const std::vector<Splat<T>>& splats, const T* splat_grads,
                     GaussianGrads<T>& out);

}  // namespace chungs::cpu
