#include "chungs/depth/stereo_depth.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace chungs {

void StereoDepthConfig::validate() const {
  if (num_disparities < 16) fail("stereo depth: num_disparities must be at least 16, got ", num_disparities);
  if (block_size < 1 || block_size % 2 == 0) fail("stereo depth: block_size must be odd and positive, got ", block_size);
  if (!(min_depth > 0) || !(max_depth > min_depth))
    fail("stereo depth: need 0 < min_depth < max_depth, got ", min_depth, " and ", max_depth);
  if (!(lr_max_diff >= 0)) fail("stereo depth: lr_max_diff must be >= 0, got ", lr_max_diff);
  if (!(confidence_sigma2 > 0)) fail("stereo depth: confidence_sigma2 must be > 0, got ", confidence_sigma2);
}

namespace {

cv::Mat gray_mat(const Image8& img) {
  cv::Mat m(img.height(), img.width(), img.channels() == 1 ? CV_8UC1 : CV_8UC(img.channels()),
            const_cast<uint8_t*>(img.data()));
  if (img.channels() == 1) return m.clone();
  cv::Mat g;
  cv::cvtColor(m, g, img.channels() == 3 ? cv::COLOR_RGB2GRAY : cv::COLOR_RGBA2GRAY);
  return g;
}

cv::Ptr<cv::StereoSGBM> make_matcher(const StereoDepthConfig& c, int num_disp) {
  const int cn = 1, b = c.block_size;
  return cv::StereoSGBM::create(0, num_disp, b, 8 * cn * b * b, 32 * cn * b * b, 1, 0, c.uniqueness,
                                c.speckle_window, c.speckle_range, cv::StereoSGBM::MODE_SGBM_3WAY);
}

}  // namespace

StereoDepth stereo_depth(const Image8& left, const Image8& right, double fx, double baseline,
                         const StereoDepthConfig& config) {
  config.validate();
  if (!left.same_size(right) || left.empty())
    fail("stereo depth: left ", left.width(), "x", left.height(), " and right ", right.width(), "x",
         right.height(), " images differ in size or are empty");
  if (!(fx > 0) || !(baseline > 0)) fail("stereo depth: need fx > 0 and baseline > 0, got ", fx, " and ", baseline);
  const int num_disp = (config.num_disparities + 15) / 16 * 16;
  const int w = left.width(), h = left.height();
  cv::Mat l = gray_mat(left), r = gray_mat(right);
  // Right disparities come from matching the mirrored pair: mirrored right becomes the "left".
  cv::Mat lf, rf, dl, dr_flipped, dr;
  cv::flip(l, lf, 1);
  cv::flip(r, rf, 1);
  auto matcher = make_matcher(config, num_disp);
  // SGBM leaves the first num_disp columns without disparity (their search range would leave the
  // image): at 310 pixels wide that was 40 % of every view, at 160 all of it. Both images get that
  // many blank columns in front, so every real column has its whole range; matches that would
  // fall in the blank part find no texture there and the left-right check drops them.
  auto match = [&](const cv::Mat& a, const cv::Mat& b, cv::Mat& out) {
    cv::Mat pa, pb, d;
    cv::copyMakeBorder(a, pa, 0, 0, num_disp, 0, cv::BORDER_CONSTANT, cv::Scalar(0));
    cv::copyMakeBorder(b, pb, 0, 0, num_disp, 0, cv::BORDER_CONSTANT, cv::Scalar(0));
    matcher->compute(pa, pb, d);
    out = d(cv::Rect(num_disp, 0, w, h)).clone();
  };
  match(l, r, dl);
  match(rf, lf, dr_flipped);
  cv::flip(dr_flipped, dr, 1);

  StereoDepth out;
  out.depth = ImageF(w, h, 1, 0.f);
  out.confidence = ImageF(w, h, 1, 0.f);
  ImageF inv(w, h, 1, 0.f);
  const double fb = fx * baseline;
  std::vector<float> valid_inv;
  for (int y = 0; y < h; ++y) {
    const int16_t* pl = dl.ptr<int16_t>(y);
    const int16_t* pr = dr.ptr<int16_t>(y);
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
