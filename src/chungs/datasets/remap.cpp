#include "chungs/datasets/remap.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>

#include "chungs/common/error.hpp"

namespace chungs::ds {

namespace {
// A cv::Mat header over an Image's pixels (no copy); OpenCV only reads from it here.
template <typename T>
cv::Mat view(const Image<T>& img, int depth) {
  return cv::Mat(img.height(), img.width(), CV_MAKETYPE(depth, img.channels()), const_cast<T*>(img.data()));
}
}  // namespace

Image8 Remap::apply(const Image8& img) const {
  Image8 out(map1_.cols, map1_.rows, img.channels());
  cv::Mat dst = view(out, CV_8U);
  cv::remap(view(img, CV_8U), dst, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

ImageF Remap::apply_nearest(const ImageF& img) const {
  ImageF out(map1_.cols, map1_.rows, img.channels());
  cv::Mat dst = view(out, CV_32F);
  cv::remap(view(img, CV_32F), dst, map1_, map2_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

double Remap::inside_share(int src_width, int src_height) const {
  if (empty()) return 1;
  size_t inside = 0;
  for (int y = 0; y < map1_.rows; ++y)
    for (int x = 0; x < map1_.cols; ++x) {
      const float u = map1_.at<float>(y, x), v = map2_.at<float>(y, x);
      inside += u >= 0 && v >= 0 && u <= float(src_width - 1) && v <= float(src_height - 1);  // nan is outside
    }
  return double(inside) / double(std::max<size_t>(1, map1_.total()));
}

void require_coverage(const Remap& map, int src_width, int src_height, const std::string& what) {
  const double share = map.inside_share(src_width, src_height);
  if (!(share >= 0.1))
    fail(what, ": its distortion and rectification leave ", 100 * share,
         " % of the image inside the camera's view (less than 10 %); the calibration is wrong");
}

cv::Mat camera_matrix(const Camera& cam) {
  return (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
}

cv::Mat dist_coeffs(const Camera& cam) {
  const auto& d = cam.dist;
  return (cv::Mat_<double>(1, 5) << d[0], d[1], d[2], d[3], d[4]);
}

Remap undistortion(const Camera& cam) {
  cv::Mat K = camera_matrix(cam), m1, m2;
  cv::initUndistortRectifyMap(K, dist_coeffs(cam), cv::Mat(), K, cv::Size(cam.width, cam.height), CV_32FC1, m1, m2);
  return Remap(m1, m2);
}

}  // namespace chungs::ds
