#include <gtest/gtest.h>

#include <random>

#include "chungs/eval/alexnet_features.hpp"
#include "lpips_fixtures.hpp"

using namespace chungs;
using test::Tensor64;

namespace {

struct Case {
  int in, out, kernel, stride, pad, width, height;
};

FeatureMap random_map(int c, int h, int w, std::mt19937& rng) {
  std::normal_distribution<float> n(0.f, 1.f);
  FeatureMap m(c, h, w);
  for (float& v : m.data) v = n(rng);
  return m;
}

Tensor64 to64(const FeatureMap& m) {
  Tensor64 t(m.channels, m.height, m.width);
  for (size_t i = 0; i < m.data.size(); ++i) t.v[i] = m.data[i];
  return t;
}

double max_rel_diff(const FeatureMap& got, const Tensor64& want) {
  EXPECT_EQ(got.channels, want.c);
  EXPECT_EQ(got.height, want.h);
  EXPECT_EQ(got.width, want.w);
  double scale = 1e-30, diff = 0;
  for (double v : want.v) scale = std::max(scale, std::abs(v));
  for (size_t i = 0; i < want.v.size() && i < got.data.size(); ++i)
    diff = std::max(diff, std::abs(double(got.data[i]) - want.v[i]));
  return diff / scale;
}

}  // namespace

// Every AlexNet conv geometry, plus odd sizes where stride and padding leave a ragged edge.
TEST(AlexnetFeatures, ConvolutionMatchesFloat64Definition) {
  std::mt19937 rng(7);
  // Channel counts around the AVX2 kernel's 6-channel panels, pixel counts around its 16-pixel
  // ones, and more taps than one of its 256-tap passes (the last case: 300).
  const Case cases[] = {{3, 8, 11, 4, 2, 45, 38}, {5, 7, 5, 1, 2, 13, 9}, {6, 4, 3, 1, 1, 10, 11},
                        {2, 3, 3, 2, 0, 9, 8},    {4, 5, 1, 1, 0, 6, 5},  {3, 6, 11, 4, 2, 71, 19},
                        {3, 13, 11, 4, 2, 31, 31}, {12, 12, 5, 1, 2, 16, 2}};
  for (const Case& k : cases) {
    const FeatureMap in = random_map(k.in, k.height, k.width, rng);
    std::uniform_real_distribution<float> u(-0.5f, 0.5f);
    std::vector<float> w(size_t(k.out) * k.in * k.kernel * k.kernel), b(size_t(k.out));
    for (float& v : w) v = u(rng);
    for (float& v : b) v = u(rng);
    const Tensor64 want = test::conv64(to64(in), w, b, k.out, k.kernel, k.stride, k.pad);
    for (ConvPath path : {ConvPath::Portable, ConvPath::Avx2}) {
      if (path == ConvPath::Avx2 && !conv2d_avx2_available()) continue;
      const FeatureMap got = conv2d(in, w.data(), b.data(), k.out, k.kernel, k.stride, k.pad, path);
      EXPECT_LT(max_rel_diff(got, want), 1e-5)
          << "kernel " << k.kernel << " stride " << k.stride << (path == ConvPath::Avx2 ? " (AVX2)" : " (portable)");
    }
  }
}

TEST(AlexnetFeatures, PoolingAndReluMatchDefinition) {
  std::mt19937 rng(8);
  for (auto [h, w] : {std::pair{7, 9}, {8, 8}, {3, 3}, {12, 5}}) {
    FeatureMap in = random_map(4, h, w, rng);
    const FeatureMap pooled = max_pool_3x3_stride2(in);
    EXPECT_EQ(max_rel_diff(pooled, test::pool64(to64(in))), 0.0) << h << "x" << w;
    relu(in);
    for (float v : in.data) EXPECT_GE(v, 0.f);
  }
  EXPECT_THROW(max_pool_3x3_stride2(FeatureMap(1, 2, 9)), Error);
}

TEST(AlexnetFeatures, ChannelNormalisationMatchesDefinition) {
  std::mt19937 rng(9);
  FeatureMap in = random_map(37, 6, 5, rng);
  for (float& v : in.data) v *= 100.f;
  EXPECT_LT(max_rel_diff(normalize_channels(in), test::normalize64(to64(in))), 1e-6);
  // An all-zero pixel (a dead ReLU) stays zero instead of dividing by zero.
  const FeatureMap zero = normalize_channels(FeatureMap(3, 2, 2));
  for (float v : zero.data) EXPECT_EQ(v, 0.f);
}

TEST(AlexnetFeatures, FiveLayersMatchFloat64OnRandomWeights) {
  std::mt19937 rng(10);
  const LpipsWeights w = test::random_lpips_weights(11);
  const ImageF img = test::random_image(47, 39, 3, rng);
  const auto got = alexnet_features(w, lpips_input(img));
  const auto want = test::features64(w, img);
  for (size_t l = 0; l < 5; ++l) EXPECT_LT(max_rel_diff(got[l], want[l]), 1e-5) << "layer " << l + 1;
}

TEST(AlexnetFeatures, RefusesImagesTooSmallForThePoolings) {
  EXPECT_NO_THROW(lpips_input(ImageF(kLpipsMinSide, kLpipsMinSide, 3)));
  EXPECT_THROW(lpips_input(ImageF(kLpipsMinSide - 1, 64, 3)), Error);
  EXPECT_THROW(lpips_input(ImageF(64, 64, 2)), Error);
  // The smallest accepted size does run through all five layers.
  const auto f = alexnet_features(test::random_lpips_weights(1), lpips_input(ImageF(kLpipsMinSide, kLpipsMinSide, 3)));
  EXPECT_EQ(f[4].height, 1);
}
