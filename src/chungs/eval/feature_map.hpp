// One image's stack of 2-D feature maps for the CPU network layers of LPIPS.
#pragma once
#include <cstddef>
#include <vector>

namespace chungs {

// Each channel's pixels contiguous in rows (PyTorch's CHW order for one image).
struct FeatureMap {
  int channels = 0, height = 0, width = 0;
  std::vector<float> data;

  FeatureMap() = default;
  FeatureMap(int c, int h, int w) : channels(c), height(h), width(w), data(size_t(c) * h * w, 0.f) {}
  size_t plane() const { return size_t(height) * size_t(width); }
  float& at(int c, int y, int x) { return data[c * plane() + size_t(y) * width + x]; }
  float at(int c, int y, int x) const { return data[c * plane() + size_t(y) * width + x]; }
};

}  // namespace chungs
