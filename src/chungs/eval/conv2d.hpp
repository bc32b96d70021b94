// 2-D convolution as PyTorch's Conv2d computes it (zero padding, floor division, bias, no
// activation), as im2col and one matrix product. Two products: Eigen's, for any x86-64, and a
// packed AVX2/FMA kernel picked at run time where the CPU has it: the build targets plain x86-64,
// on which Eigen uses SSE only, and AlexNet on a KITTI image is ~13 GFLOP.
#pragma once
#include "chungs/eval/feature_map.hpp"

namespace chungs {

enum class ConvPath { Auto, Portable, Avx2 };

bool conv2d_avx2_available();

// weight: [out][in.channels][kernel][kernel]; bias: [out]. Avx2 on a CPU without it is an Error.
FeatureMap conv2d(const FeatureMap& in, const float* weight, const float* bias, int out, int kernel, int stride,
                  int pad, ConvPath path = ConvPath::Auto);

}  // namespace chungs
