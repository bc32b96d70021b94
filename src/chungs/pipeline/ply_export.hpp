// Export of a map folder as a standard 3D Gaussian Splatting PLY (what SuperSplat and other viewers
// open): binary little-endian float32 x y z nx ny nz f_dc_0..2 f_rest_0..44 opacity scale_0..2
// rot_0..3, opacity as a logit, scales as natural logs, rotation (w, x, y, z); f_rest channel-major
// (the 15 higher coefficients of red, then green, then blue), converted from our coefficient-major
// SoA sh[48 i + 3 k + c].
#pragma once
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <vector>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/store/chunk_store.hpp"

namespace chungs {

struct PlySelection {
  std::optional<ChunkId> chunk;                    // one chunk only
  std::optional<Eigen::Vector3d> box_lo, box_hi;  // Gaussians whose mean lies in the box
};

// Writes the selected Gaussians of the store's map; returns how many. Error names the file.
uint64_t export_ply(const ChunkStore& store, const std::filesystem::path& file, const PlySelection& select = {});
// Writes one block (all its Gaussians).
void write_gaussian_ply(const std::filesystem::path& file, const std::vector<const GaussianBlock*>& blocks);

}  // namespace chungs
