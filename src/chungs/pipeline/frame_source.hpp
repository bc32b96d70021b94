// Frames for the mapper: the dataset's images at the mapping resolution, a pose from the chosen
// source (ground truth or a trajectory file), and depth from the chosen depth source.
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/depth/depth_source.hpp"

namespace chungs {

// Poses per frame: "gt" (the dataset's ground truth) or a TUM/KITTI trajectory file. KITTI files
// (no stamps) pair by index; TUM files by nearest stamp within max_dt. Frames without a pose get
// none (they are skipped).
std::vector<std::optional<SE3>> frame_poses(const Dataset& dataset, const std::string& source, double max_dt = 0.02);

// Area-averaged downscale by an integer factor, bilinear otherwise (8-bit, any channels).
Image8 scale_image(const Image8& img, double factor);
// Depth downscale: nearest valid sample (no averaging across depth edges).
ImageF scale_depth(const ImageF& depth, int width, int height);

struct MappingFrame {
  Frame frame;                  // images and camera at the mapping resolution
  std::optional<ImageF> depth;  // metres, 0 invalid
  double median_depth = 0;      // of the valid depth pixels (0: no depth)
  // Multiview depth: earlier keyframes whose depth waited for a neighbour, computed with this one's
  // load (frame index, depth at the mapping resolution).
  std::vector<std::pair<size_t, ImageF>> late_depth;
  // An earlier keyframe's guessed depths made again with this one (frame index, depth at its guesses).
  std::vector<std::pair<size_t, ImageF>> refresh_depth;
};

// Median of the finite positive values (0 when there are none).
double median_valid_depth(const ImageF& depth);

// Loads frame i, scales it and computes its depth by the mode (stereo runs at the scaled size with
// the disparity range scaled alike).
MappingFrame load_mapping_frame(const Dataset& dataset, size_t i, double resolution, DepthMode mode,
                                StereoDepthConfig stereo, bool want_depth = true);

}  // namespace chungs
