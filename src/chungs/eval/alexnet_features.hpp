// AlexNet's feature layers as LPIPS uses them, on the CPU in float32: convolution (conv2d.hpp),
// ReLU, 3x3 stride-2 max pooling, and the channel normalisation LPIPS applies to each layer.
// Shapes follow PyTorch (floor division, no padding in the pools), so a layer matches torch.nn's.
#pragma once
#include <array>
#include <cstddef>
#include <vector>

#include "chungs/eval/conv2d.hpp"
#include "chungs/eval/feature_map.hpp"
#include "chungs/eval/lpips_weights.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

void relu(FeatureMap& m);
FeatureMap max_pool_3x3_stride2(const FeatureMap& in);
// x / (sqrt(sum over channels of x^2) + 1e-10) at every pixel.
FeatureMap normalize_channels(const FeatureMap& in);

// RGB (gray replicated) in [0, 1] mapped to [-1, 1] and through LPIPS's fixed scaling layer.
FeatureMap lpips_input(const ImageF& image);
// The outputs of the five ReLUs after conv1..conv5.
std::array<FeatureMap, 5> alexnet_features(const LpipsWeights& w, const FeatureMap& input);

}  // namespace chungs
