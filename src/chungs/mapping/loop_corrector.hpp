// Loop closure in the chunked map: when keyframe poses jump (a loop closed, or local bundle
// adjustment moved them), the Gaussians each keyframe created move rigidly with it,
// mean' = D * mean and q' = D.q * q with D = T_new * T_old^-1; scales are unchanged; the
// view-dependent SH bands (degree 1..3) are rotated with D, so that the moved Gaussian shows the
// colour it showed before to a camera that moved with it (the DC term does not change).
//
// Only the chunks that hold Gaussians of the moved keyframes are visited (KeyframeChunkIndex),
// each exactly once; every Gaussian of a visited chunk is re-filed by its position (the optimiser
// may have carried unmoved ones out of their chunk before). A Gaussian that leaves its chunk is appended to
// its new chunk right away when that chunk will not be visited (or already was); when the destination is
// still to be visited it waits in host memory until the visiting is over, so no Gaussian is transformed
// twice. Batch mode pins all visited chunks at once under a temporarily raised budget (up to the pool's
// capacity); when they do not fit, chunks are visited one at a time under the normal budget.
#pragma once
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <span>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "chungs/common/text_pieces.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/residency/residency.hpp"

namespace chungs {

struct PoseCorrectionStats {
  size_t keyframes = 0, gaussians_moved = 0, chunks_touched = 0, chunks_created = 0,
         gaussians_changed_chunk = 0, junction_gaussians = 0;
  bool batch = false;
  double apply_ms = 0, refine_ms = 0;
  nlohmann::json to_json() const;
};

// Which chunks may hold Gaussians created by each keyframe. A superset: pruning is not tracked.
// An index that was not saved with the map (older folders) is incomplete: every chunk is a
// candidate then.
class KeyframeChunkIndex {
 public:
  void add(uint32_t keyframe, ChunkId chunk);
  // Chunks listed for any of the keyframes, ascending and unique.
  std::vector<ChunkId> chunks_of(std::span<const uint32_t> keyframes) const;
  bool complete() const { return complete_; }
  void set_incomplete() { complete_ = false; }
  // Appends {"<keyframe>": [chunk ids as hex strings], ...} (keyframes ascending) as JSON text. Text,
  // not a JSON tree: a tree of a 10 km drive's index (~220 k ids) took ~30 MB at every checkpoint, and
  // that peak, growing with the drive, raised the host memory's high-water mark at each one.
  void append_json(TextPieces& out) const;
  size_t entries() const;  // chunk ids listed, over all keyframes
  // Throws Error naming the entry on malformed input.
  static KeyframeChunkIndex from_json(const nlohmann::json& j);

 private:
  std::unordered_map<uint32_t, std::vector<ChunkId>> chunks_;  // each list sorted, unique
  bool complete_ = true;
};

struct PoseCorrection {
  std::unordered_map<uint32_t, SE3> delta;  // keyframe id -> T_new * T_old^-1
  std::unordered_set<uint32_t> junction;    // keyframes whose Gaussians are reset for refinement
  float reset_opacity_logit = 0;            // opacity logit given to junction Gaussians
  bool allow_batch = true;                  // false: always one chunk at a time
  // Changes of single Gaussians besides the keyframes' rigid ones (Mapper::redepth): changes Gaussian
  // i of the block in place and says whether it did.
  std::function<bool(GaussianBlock& block, size_t i)> reshape;
};

// Applies the correction to the Gaussians in `candidates` (chunks of the map; unknown ones are
// skipped) through the residency, so the pool (host or device) and the chunk files stay in step.
// Junction Gaussians get the reset opacity and zero Adam moments and steps. The index learns the
// new chunks of moved Gaussians. Fills every field of the stats but keyframes and refine_ms.
PoseCorrectionStats apply_pose_correction(Residency& residency, double chunk_size,
                                          const PoseCorrection& correction,
                                          std::span<const ChunkId> candidates, KeyframeChunkIndex& index);

// The rigid change of one Gaussian (exposed for tests): mean and rotation (w, x, y, z) in place.
void transform_gaussian(const SE3& delta, float* mean, float* rotation);

// Rotation of the SH bands 1..3 by a rotation R: for each band l a (2l+1)^2 matrix M_l with
// sum_k (M_l f)_k b_k(d) = sum_k f_k b_k(R^T d) for every direction d (the basis of render/sh.hpp).
struct ShRotation {
  Eigen::Matrix<double, 3, 3> band1;
  Eigen::Matrix<double, 5, 5> band2;
  Eigen::Matrix<double, 7, 7> band3;
};
ShRotation sh_rotation(const Eigen::Matrix3d& R);
// Rotates the coefficients of degrees 1..degree of one Gaussian (kShFloats floats, sh[3k + c]).
void rotate_sh(const ShRotation& m, int degree, float* sh);

}  // namespace chungs
