#include "chungs/image/image.hpp"

#include <algorithm>
#include <cmath>

namespace chungs {

ImageF to_float(const Image8& img) {
  ImageF out(img.width(), img.height(), img.channels());
  for (size_t i = 0; i < img.size(); ++i) out.data()[i] = img.data()[i] / 255.0f;
  return out;
}

Image8 to_u8(const ImageF& img) {
  Image8 out(img.width(), img.height(), img.channels());
  for (size_t i = 0; i < img.size(); ++i) {
    float v = std::isfinite(img.data()[i]) ? img.data()[i] : 0.0f;
    out.data()[i] = uint8_t(std::clamp(std::lround(v * 255.0f), 0L, 255L));
  }
  return out;
}

template <typename T, typename Acc>
static Image<T> gray_of(const Image<T>& img) {
  if (img.channels() == 1) return img;
  if (img.channels() < 3) fail("to_gray: expected 1, 3 or 4 channels, got ", img.channels());
  Image<T> out(img.width(), img.height(), 1);
  for (size_t i = 0; i < img.pixels(); ++i) {
    const T* p = img.data() + i * img.channels();
    Acc v = Acc(0.299) * p[0] + Acc(0.587) * p[1] + Acc(0.114) * p[2];
    if constexpr (std::is_integral_v<T>)
      out.data()[i] = T(std::clamp<long>(std::lround(v), 0, 255));
    else
      out.data()[i] = T(v);
  }
  return out;
}

ImageF to_gray(const ImageF& img) { return gray_of<float, float>(img); }
Image8 to_gray(const Image8& img) { return gray_of<uint8_t, double>(img); }

ImageF to_rgb(const ImageF& img) {
  if (img.channels() == 3) return img;
  ImageF out(img.width(), img.height(), 3);
  for (size_t i = 0; i < img.pixels(); ++i)
    for (int c = 0; c < 3; ++c)
      out.data()[i * 3 + c] = img.data()[i * img.channels() + std::min(c, img.channels() - 1)];
  return out;
}

Image8 box_downscale(const Image8& img, int k, int width, int height) {
  const int ch = img.channels();
  Image8 out(width, height, ch);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < ch; ++c) {
        int sum = 0, cnt = 0;
        for (int yy = y * k; yy < std::min((y + 1) * k, img.height()); ++yy)
          for (int xx = x * k; xx < std::min((x + 1) * k, img.width()); ++xx) sum += img(xx, yy, c), ++cnt;
        out(x, y, c) = uint8_t((sum + cnt / 2) / std::max(cnt, 1));
      }
  return out;
}

ImageF resize_bilinear(const ImageF& img, int width, int height) {
  if (width <= 0 || height <= 0) fail("resize: invalid target size ", width, "x", height);
  ImageF out(width, height, img.channels());
  const double sx = double(img.width()) / width, sy = double(img.height()) / height;
  for (int y = 0; y < height; ++y) {
    double fy = std::clamp((y + 0.5) * sy - 0.5, 0.0, img.height() - 1.0);
    int y0 = int(fy), y1 = std::min(y0 + 1, img.height() - 1);
    double wy = fy - y0;
    for (int x = 0; x < width; ++x) {
      double fx = std::clamp((x + 0.5) * sx - 0.5, 0.0, img.width() - 1.0);
      int x0 = int(fx), x1 = std::min(x0 + 1, img.width() - 1);
      double wx = fx - x0;
      for (int c = 0; c < img.channels(); ++c) {
        double v = (1 - wy) * ((1 - wx) * img(x0, y0, c) + wx * img(x1, y0, c)) +
                   wy * ((1 - wx) * img(x0, y1, c) + wx * img(x1, y1, c));
        out(x, y, c) = float(v);
      }
    }
  }
  return out;
}

}  // namespace chungs
