// The rasterizer benchmark workload, shared by the CPU and CUDA benchmarks so their figures compare.
// Camera at the origin looking down +z (identity pose), principal point at the image centre.
// Per Gaussian: depth z = 2 + 58 u^1.5 (u uniform in [0,1)); pixel position uniform over the image,
// back-projected at that depth; log scale per axis ~ Normal(ln 0.03, 0.5), then the scale multiplied
// by max(z / 10, 0.3); rotation a normalised 4-vector of standard normals; opacity =
// sigmoid(Normal(0, 1)) (stored as that logit); all 16x3 SH coefficients ~ Normal(0, 0.2^2).
// The loss is sum(image * weights) with a fixed uniform [0,1) weight per pixel and channel.
#pragma once
#include <cstddef>
#include <cstdint>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/geometry/camera.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

Camera bench_camera_vga();    // 640 x 480, f = 525
Camera bench_camera_kitti();  // 1241 x 376, f = 718

GaussianParams make_bench_gaussians(size_t n, const Camera& camera, uint64_t seed = 1);
Image<float> make_bench_weights(int width, int height, uint64_t seed = 2);  // 3 channels

}  // namespace chungs
