// AlexNet's feature layers as LPIPS uses them, on the CPU in float32: convolution as im2col and one
// Eigen GEMM, ReLU, 3x3 stride-2 max pooling, and the channel normalisation LPIPS applies to each
// layer. Shapes follow PyTorch (floor division, zero padding), so a layer matches torch.nn's.
#pragma once
#include <array>
#include <cstddef>
#include <vector>

#include "chungs/eval/lpips_weights.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

// One image's feature maps, each channel's pixels contiguous in rows (PyTorch's CHW order).
struct FeatureMap {
  int channels = 0, height = 0, width = 0;
  std::vector<float> data;

  FeatureMap() = default;
  FeatureMap(int c, int h, int w) : channels(c), height(h), width(w), data(size_t(c) * h * w, 0.f) {}
  size_t plane() const { return size_t(height) * size_t(width); }
  float& at(int c, int y, int x) { return data[c * plane() + size_t(y) * width + x]; }
  float at(int c, int y, int x) const { return data[c * plane() + size_t(y) * width + x]; }
};

// weight: [out][in.channels][kernel][kernel]; bias: [out]. No activation.
FeatureMap conv2d(const FeatureMap& in, const float* weight, const float* bias, int out, int kernel, int stride,
                  int pad);
void relu(FeatureMap& m);
FeatureMap max_pool_3x3_stride2(const FeatureMap& in);
// x / (sqrt(sum over channels of x^2) + 1e-10) at every pixel.
FeatureMap normalize_channels(const FeatureMap& in);

// RGB (gray replicated) in [0, 1] mapped to [-1, 1] and through LPIPS's fixed scaling layer.
FeatureMap lpips_input(const ImageF& image);
// The outputs of the five ReLUs after conv1..conv5.
std::array<FeatureMap, 5> alexnet_features(const LpipsWeights& w, const FeatureMap& input);

}  // namespace chungs
