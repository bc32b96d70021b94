// Metric depth from a rectified stereo pair: semi-global matching (sgm.hpp; on the GPU when asked),
// a speckle filter, a left-right consistency check against the right view's winners, and a
// confidence map from the smoothness of the inverse depth.
#pragma once
#include "chungs/depth/sgm.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

struct StereoDepthConfig {
  int num_disparities = 128;  // search range in pixels, at most 256
  int p1 = 10, p2 = 120;      // matching penalties of small and large disparity changes (sgm.hpp)
  int uniqueness = 10;        // percent by which the best match must beat the others
  int speckle_window = 100;   // speckle filter region (pixels), 0 = off
  int speckle_range = 2;
  double lr_max_diff = 1.0;   // left and right disparities must agree to this many pixels
  double min_depth = 0.5, max_depth = 80.0;  // metres kept
  double min_disparity_px = 1.0;
  // Confidence exp(-|Sobel(inverse depth)|^2 / confidence_sigma2) with inverse depth scaled by
  // the median of the valid ones (scale free); pixels below min_confidence are dropped.
  double confidence_sigma2 = 0.2;
  double min_confidence = 0.0;
  bool cuda = false;  // match on the GPU (chosen by the run's device, not a file setting)
  void validate() const;
  SgmParams sgm_params() const;  // the matcher's share of these settings
};

struct StereoDepth {
  ImageF depth;       // metres along the optical axis, 0 where invalid
  ImageF confidence;  // [0, 1], 0 where invalid
  size_t valid = 0;
};

// left/right: same size, gray or RGB, rectified (rows correspond). fx in pixels, baseline in metres.
// Throws Error on mismatched shapes or a non-positive focal length or baseline.
StereoDepth stereo_depth(const Image8& left, const Image8& right, double fx, double baseline,
                         const StereoDepthConfig& config = {});

}  // namespace chungs
