// A bag's decoded picture (rosbag_io.hpp, plain data from the C++17 reader) as the library's images.
#pragma once
#include <algorithm>

#include "chungs/datasets/rosbag_io.hpp"
#include "chungs/image/image.hpp"

namespace chungs::rosbag_io {

inline Image8 image_of(const Picture& p) {
  Image8 img(p.width, p.height, p.channels);
  std::copy(p.pixels.begin(), p.pixels.end(), img.data());
  return img;
}

inline ImageF depth_of(const Picture& p) {
  ImageF img(p.width, p.height, 1);
  std::copy(p.metres.begin(), p.metres.end(), img.data());
  return img;
}

}  // namespace chungs::rosbag_io
