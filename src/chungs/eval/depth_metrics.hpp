// Depth quality against ground truth: AbsRel (mean |d - d*| / d*) and delta < 1.25 (share of pixels
// with max(d / d*, d* / d) < 1.25), over the pixels where both depths are valid (positive and
// finite; 0 means invalid throughout the project). No scale alignment: metric depth is scored as it
// is (align a monocular estimate before scoring it).
#pragma once
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "chungs/eval/image_set.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

struct DepthMetrics {
  double abs_rel = 0;   // NaN when no pixel is valid in both
  double delta1 = 0;    // fraction in [0, 1], NaN when none
  double rmse = 0;      // metres, NaN when none
  size_t pixels = 0;    // valid in both (and kept by the mask)
  size_t gt_valid = 0;  // valid in the ground truth (and kept by the mask): coverage = pixels / gt_valid
};

// Sums over pixels, so a set of images is scored over all its pixels at once.
class DepthErrorSum {
 public:
  // Same width and height, 1 channel (mask: 1 channel, pixels with 0 are skipped), else Error naming `what`.
  void add(const ImageF& gt, const ImageF& est, const Image8* mask = nullptr, const std::string& what = "depth");
  // Depth at single points (sampled pixels): ignored unless both are valid.
  void add(double gt, double est);
  DepthMetrics result() const;

 private:
  double abs_rel_ = 0, sq_ = 0;
  size_t inliers_ = 0, pixels_ = 0, gt_valid_ = 0;
};

DepthMetrics compare_depth(const ImageF& gt, const ImageF& est, const Image8* mask = nullptr);

// A 1-channel 16-bit PNG divided by `scale` (TUM: 5000, millimetres: 1000), 0 stays invalid. Throws
// Error naming the file for an 8-bit or multi-channel file or a scale that is not positive.
ImageF read_depth_png(const std::filesystem::path& file, double scale);

struct DepthPairResult {
  ImagePair pair;  // ref = ground truth, test = estimate
  DepthMetrics metrics;
};
struct DepthSetResult {
  std::vector<DepthPairResult> images;
  DepthMetrics pooled;  // over all pixels of all pairs
};
// Pairs by name as `eval images` does (match_image_pairs); every pair must have one size.
DepthSetResult evaluate_depth_pairs(const std::vector<ImagePair>& pairs, double gt_scale, double est_scale);

}  // namespace chungs
