// Image helpers shared by the metric tests.
#pragma once
#include <algorithm>

#include "chungs/image/image.hpp"

namespace chungs::test {

// Mean over a (2r+1)^2 window with clamped borders: a known, monotone degradation for metric tests.
inline ImageF box_blur(const ImageF& img, int r) {
  ImageF out(img.width(), img.height(), img.channels());
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < img.channels(); ++c) {
        double s = 0;
        int n = 0;
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            int yy = std::clamp(y + dy, 0, img.height() - 1), xx = std::clamp(x + dx, 0, img.width() - 1);
            s += img(xx, yy, c), ++n;
          }
        out(x, y, c) = float(s / n);
      }
  return out;
}

}  // namespace chungs::test
