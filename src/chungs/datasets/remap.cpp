#include "chungs/datasets/remap.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

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
