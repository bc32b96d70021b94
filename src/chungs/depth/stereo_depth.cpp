#include "chungs/depth/stereo_depth.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#if CHUNGS_WITH_CUDA
#include "chungs/depth/cuda/sgm_cuda.hpp"
#endif

namespace chungs {

void StereoDepthConfig::validate() const {
  // Checked here, not only by the matcher, so the message names this section's key.
  if (num_disparities < 16 || num_disparities > kSgmMaxDisparities)
    fail("stereo depth: num_disparities must be in [16, ", kSgmMaxDisparities, "], got ", num_disparities);
  sgm_params().validate();  // the penalties, the uniqueness margin
  if (speckle_window < 0 || speckle_range < 0)
    fail("stereo depth: speckle_window and speckle_range must be >= 0, got ", speckle_window, " and ", speckle_range);
  if (!(min_depth > 0) || !(max_depth > min_depth) || !std::isfinite(max_depth))
    fail("stereo depth: need 0 < min_depth < max_depth, both finite, got ", min_depth, " and ", max_depth);
  if (!(lr_max_diff >= 0) || !std::isfinite(lr_max_diff))
    fail("stereo depth: lr_max_diff must be a finite number >= 0, got ", lr_max_diff);
  if (!(confidence_sigma2 > 0) || !std::isfinite(confidence_sigma2))
    fail("stereo depth: confidence_sigma2 must be a finite number > 0, got ", confidence_sigma2);
  // Unchecked, nan turned the filters off (every comparison with it is false).
  if (!(min_disparity_px >= 0) || !std::isfinite(min_disparity_px))
    fail("stereo depth: min_disparity_px must be a finite number >= 0, got ", min_disparity_px);
  if (!(min_confidence >= 0 && min_confidence <= 1))
    fail("stereo depth: min_confidence must be in [0, 1], got ", min_confidence);
#if !CHUNGS_WITH_CUDA
  if (cuda) fail("stereo depth: this build has no CUDA backend");
#endif
}

SgmParams StereoDepthConfig::sgm_params() const {
  SgmParams p;
  p.disparities = num_disparities;
  p.p1 = p1, p.p2 = p2, p.uniqueness = uniqueness;
  return p;
}

StereoDepth stereo_depth(const Image8& left, const Image8& right, double fx, double baseline,
                         const StereoDepthConfig& config) {
  config.validate();
  if (!left.same_size(right) || left.empty())
    fail("stereo depth: left ", left.width(), "x", left.height(), " and right ", right.width(), "x",
         right.height(), " images differ in size or are empty");
  if (!(fx > 0) || !(baseline > 0)) fail("stereo depth: need fx > 0 and baseline > 0, got ", fx, " and ", baseline);
  const int w = left.width(), h = left.height();
  const SgmParams params = config.sgm_params();
  const Image8 l = to_gray(left), r = to_gray(right);
#if CHUNGS_WITH_CUDA
  SgmDisparities disp = config.cuda ? cuda::sgm_disparities(l, r, params) : sgm_disparities(l, r, params);
#else
  SgmDisparities disp = sgm_disparities(l, r, params);
#endif
  if (config.speckle_window > 0) {
    // Small islands of disparity that differ from their surroundings are mismatches.
    cv::Mat dl(h, w, CV_16S, disp.left.data());
    cv::filterSpeckles(dl, kNoDisparity, config.speckle_window, 16 * config.speckle_range);
  }

  StereoDepth out;
  out.depth = ImageF(w, h, 1, 0.f);
  out.confidence = ImageF(w, h, 1, 0.f);
  ImageF inv(w, h, 1, 0.f);
  const double fb = fx * baseline;
  std::vector<float> valid_inv;
  for (int y = 0; y < h; ++y) {
    const int16_t* pl = &disp.left[size_t(y) * w];
    const int16_t* pr = &disp.right[size_t(y) * w];
    for (int x = 0; x < w; ++x) {
      if (pl[x] <= 0) continue;
      const double d = pl[x] / 16.0;
      if (d < config.min_disparity_px) continue;
      const int xr = int(std::lround(x - d));
      if (xr < 0 || xr >= w || pr[xr] <= 0) continue;
      if (std::abs(pr[xr] / 16.0 - d) > config.lr_max_diff) continue;
      const double z = fb / d;
      if (z < config.min_depth || z > config.max_depth) continue;
      out.depth(x, y) = float(z);
      inv(x, y) = float(1.0 / z);
      valid_inv.push_back(inv(x, y));
    }
  }
  if (valid_inv.empty()) return out;
  std::nth_element(valid_inv.begin(), valid_inv.begin() + valid_inv.size() / 2, valid_inv.end());
  const double med = valid_inv[valid_inv.size() / 2];
  cv::Mat invm(h, w, CV_32F, inv.data()), gx, gy;
  cv::Sobel(invm, gx, CV_32F, 1, 0, 3);
  cv::Sobel(invm, gy, CV_32F, 0, 1, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (out.depth(x, y) <= 0) continue;
      // A neighbour without depth makes the Sobel response meaningless: low confidence there.
      bool edge = x == 0 || y == 0 || x == w - 1 || y == h - 1;
      for (int dy = -1; dy <= 1 && !edge; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (inv(x + dx, y + dy) <= 0) edge = true;
      const double g2 = (double(gx.at<float>(y, x)) * gx.at<float>(y, x) + double(gy.at<float>(y, x)) * gy.at<float>(y, x)) /
                        (med * med);
      const float conf = edge ? 0.f : float(std::exp(-g2 / config.confidence_sigma2));
      if (conf < config.min_confidence || (edge && config.min_confidence > 0)) {
        out.depth(x, y) = 0;
        continue;
      }
      out.confidence(x, y) = conf;
      ++out.valid;
    }
  return out;
}

}  // namespace chungs
