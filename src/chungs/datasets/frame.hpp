// The one Frame type every dataset reader produces and every module consumes.
#pragma once
#include <filesystem>
#include <optional>
#include <string>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

struct Frame {
  size_t index = 0;                // position in the sequence, 0-based
  double timestamp = 0;            // seconds
  Image8 left;                     // gray (1 channel) or RGB (3); undistorted/rectified
  std::optional<Image8> right;     // rectified right image of a stereo pair
  std::optional<ImageF> depth;     // metres along the optical axis, 0 where invalid
  std::optional<SE3> gt_pose;      // ground truth, left camera-to-world
  Camera camera;                   // left camera, distortion removed by the reader
  double baseline = 0;             // metres between rectified stereo centres; 0 without stereo
  std::string source;              // file of the left image, for messages
};

}  // namespace chungs
