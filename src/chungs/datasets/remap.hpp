// Pixel remapping for undistortion and stereo rectification, through OpenCV's lookup maps. The
// maps are built once per sequence and applied to every frame.
#pragma once
#include <opencv2/core.hpp>
#include <string>

#include "chungs/geometry/camera.hpp"
#include "chungs/image/image.hpp"

namespace chungs::ds {

class Remap {
 public:
  Remap() = default;
  Remap(cv::Mat map1, cv::Mat map2) : map1_(std::move(map1)), map2_(std::move(map2)) {}
  bool empty() const { return map1_.empty(); }
  Image8 apply(const Image8& img) const;          // bilinear, black outside the source
  ImageF apply_nearest(const ImageF& img) const;  // nearest: depth must not blend valid with invalid (0)
  // Share of the output's pixels that look up a point inside a src_width x src_height source.
  double inside_share(int src_width, int src_height) const;

 private:
  // Float maps (CV_32FC1 x and y): with fixed-point maps, nearest lookup would floor instead of round.
  cv::Mat map1_, map2_;
};

cv::Mat camera_matrix(const Camera& cam);  // 3x3 CV_64F
cv::Mat dist_coeffs(const Camera& cam);    // 1x5 CV_64F, OpenCV order k1 k2 p1 p2 k3

// Throws naming `what` when the map leaves under a tenth of its output inside the source: finite but absurd
// coefficients (a bag's D of 1e30) made every frame black, a map of 0 Gaussians that blamed the depth.
void require_coverage(const Remap& map, int src_width, int src_height, const std::string& what);

// Maps a distorted camera's images to the same intrinsics without distortion.
Remap undistortion(const Camera& cam);

}  // namespace chungs::ds
