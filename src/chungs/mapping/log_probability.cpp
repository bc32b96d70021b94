#include "chungs/mapping/log_probability.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace chungs {

namespace {

// 3x3 mean with the edge pixel repeated, per channel.
ImageF box3(const ImageF& in) {
  const int w = in.width(), h = in.height(), ch = in.channels();
  ImageF tmp(w, h, ch), out(w, h, ch);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < ch; ++c)
        tmp(x, y, c) = (in(std::max(x - 1, 0), y, c) + in(x, y, c) + in(std::min(x + 1, w - 1), y, c)) / 3.f;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < ch; ++c)
        out(x, y, c) = (tmp(x, std::max(y - 1, 0), c) + tmp(x, y, c) + tmp(x, std::min(y + 1, h - 1), c)) / 3.f;
  return out;
}

}  // namespace

ImageF log_probability(const ImageF& image) {
  const int w = image.width(), h = image.height(), ch = image.channels();
  ImageF p(w, h, 1, 0.f);
  if (w < 3 || h < 3) return p;
  const ImageF b = box3(box3(image));
  ImageF lap(w, h, 1, 0.f);
  for (int y = 1; y < h - 1; ++y)
    for (int x = 1; x < w - 1; ++x) {
      float s = 0;
      for (int c = 0; c < ch; ++c)
        s += b(x - 1, y, c) + b(x + 1, y, c) + b(x, y - 1, c) + b(x, y + 1, c) - 4.f * b(x, y, c);
      lap(x, y) = std::abs(s);
    }
  // Disc offsets of radius 3.5 inside the 7x7 window; pixels beyond the image count as zero.
  std::vector<std::pair<int, int>> disc;
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx)
      if (dx * dx + dy * dy <= 12.25) disc.emplace_back(dx, dy);
  const float inv = 1.f / float(disc.size());
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float s = 0;
      for (auto [dx, dy] : disc) {
        const int xx = x + dx, yy = y + dy;
        if (xx >= 0 && yy >= 0 && xx < w && yy < h) s += lap(xx, yy);
      }
      p(x, y) = std::clamp(s * inv, 0.f, 1.f);
    }
  return p;
}

}  // namespace chungs
