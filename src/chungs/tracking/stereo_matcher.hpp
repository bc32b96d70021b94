// Depth for left-image features: stereo matching along rectified rows with sub-pixel refinement, or
// a depth map's value under the feature (RGB-D), which gets a virtual right column for the same residuals.
#pragma once
#include <opencv2/core.hpp>

#include "chungs/image/image.hpp"
#include "chungs/tracking/features.hpp"

namespace chungs::tracking {

struct StereoOptions {
  int max_descriptor_distance = 75;  // of 256 bits
  float min_depth = 0.1f;            // metres; bounds the disparity search
  int patch_radius = 5;              // SAD window (11 x 11) for the sub-pixel step
  int search_radius = 5;             // pixels either side of the descriptor match
};

// Fills left.depth and left.u_right from features of the right image; `bf` = fx * baseline.
// Returns the number of features that got a depth.
int match_stereo(const cv::Mat& left_gray, const cv::Mat& right_gray, Features& left, const Features& right,
                 double bf, const StereoOptions& opt = {});

// Fills depth (metres, 0 = invalid) from a depth map of the left image's size; u_right = u - bf / depth with a
// virtual baseline so RGB-D and stereo share one residual. Returns the number of features with a depth.
int attach_depth(const ImageF& depth, Features& f, double bf, float min_depth = 0.1f, float max_depth = 30.f);

}  // namespace chungs::tracking
