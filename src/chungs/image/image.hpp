// Image<T>: an owning, interleaved, row-major image with 1..4 channels. Pixel (x, y) channel c is
// data[(y * width + x) * channels + c].
#pragma once
#include <cstdint>
#include <vector>

#include "chungs/common/error.hpp"

namespace chungs {

// The most pixels an image read from a file may have (8192 x 8192, beyond 8K video): a header that
// declares more is refused before anything is allocated for it.
constexpr uint64_t kMaxImagePixels = uint64_t(1) << 26;

template <typename T>
class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels = 1, T fill = T{})
      : width_(width), height_(height), channels_(channels) {
    if (width < 0 || height < 0 || channels < 1 || channels > 4)
      fail("image: invalid shape ", width, "x", height, "x", channels);
    data_.assign(size_t(width) * size_t(height) * size_t(channels), fill);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  size_t size() const { return data_.size(); }
  size_t pixels() const { return size_t(width_) * size_t(height_); }
  bool same_shape(const Image& o) const {
    return width_ == o.width_ && height_ == o.height_ && channels_ == o.channels_;
  }
  template <typename U>
  bool same_size(const Image<U>& o) const { return width_ == o.width() && height_ == o.height(); }

  T& operator()(int x, int y, int c = 0) { return data_[(size_t(y) * width_ + x) * channels_ + c]; }
  const T& operator()(int x, int y, int c = 0) const {
    return data_[(size_t(y) * width_ + x) * channels_ + c];
  }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  T* row(int y) { return data_.data() + size_t(y) * width_ * channels_; }
  const T* row(int y) const { return data_.data() + size_t(y) * width_ * channels_; }
  std::vector<T>& vec() { return data_; }
  const std::vector<T>& vec() const { return data_; }

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  std::vector<T> data_;
};

using Image8 = Image<uint8_t>;
using Image16 = Image<uint16_t>;
using ImageF = Image<float>;

// Conversions. Float images of colour are in [0, 1].
ImageF to_float(const Image8& img);                       // /255
Image8 to_u8(const ImageF& img);                          // *255, rounded and clamped
ImageF to_gray(const ImageF& img);                        // Rec. 601 luma; 1-channel input is copied
Image8 to_gray(const Image8& img);
ImageF to_rgb(const ImageF& img);                         // gray replicated; 3-channel copied
// Bilinear resize with pixel centres aligned (no anti-aliasing: blur first for big downscales).
ImageF resize_bilinear(const ImageF& img, int width, int height);
// width x height pixels, each the rounded mean of the k x k block at (k x, k y), of its part inside
// the image (a reduction by an integer factor; a block wholly outside gives 0).
Image8 box_downscale(const Image8& img, int k, int width, int height);

}  // namespace chungs
