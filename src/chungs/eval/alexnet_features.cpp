#include "chungs/eval/alexnet_features.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

namespace {

int out_size(int in, int kernel, int stride, int pad) {
  const int span = in + 2 * pad - kernel;
  return span < 0 ? 0 : span / stride + 1;
}

}  // namespace

void relu(FeatureMap& m) {
  for (float& v : m.data) v = std::max(v, 0.f);
}

FeatureMap max_pool_3x3_stride2(const FeatureMap& in) {
  const int oh = out_size(in.height, 3, 2, 0), ow = out_size(in.width, 3, 2, 0);
  if (oh < 1 || ow < 1) fail("max pool: ", in.width, "x", in.height, " input is smaller than 3x3");
  FeatureMap res(in.channels, oh, ow);
#pragma omp parallel for schedule(static)
  for (int c = 0; c < in.channels; ++c)
    for (int y = 0; y < oh; ++y)
      for (int x = 0; x < ow; ++x) {
        float m = in.at(c, 2 * y, 2 * x);
        for (int dy = 0; dy < 3; ++dy)
          for (int dx = 0; dx < 3; ++dx) m = std::max(m, in.at(c, 2 * y + dy, 2 * x + dx));
        res.at(c, y, x) = m;
      }
  return res;
}

FeatureMap normalize_channels(const FeatureMap& in) {
  FeatureMap res(in.channels, in.height, in.width);
  const size_t n = in.plane();
#pragma omp parallel for schedule(static)
  for (size_t p = 0; p < n; ++p) {
    double sum = 0;
    for (int c = 0; c < in.channels; ++c) sum += double(in.data[c * n + p]) * in.data[c * n + p];
    const double inv = 1.0 / (std::sqrt(sum) + 1e-10);
    for (int c = 0; c < in.channels; ++c) res.data[c * n + p] = float(in.data[c * n + p] * inv);
  }
  return res;
}

FeatureMap lpips_input(const ImageF& image) {
  if (image.channels() != 1 && image.channels() != 3)
    fail("LPIPS: images must be gray or RGB, got ", image.channels(), " channels");
  if (image.width() < kLpipsMinSide || image.height() < kLpipsMinSide)
    fail("LPIPS: images must be at least ", kLpipsMinSide, "x", kLpipsMinSide, " pixels, got ", image.width(), "x",
         image.height());
  // The constants of LPIPS v0.1's ScalingLayer: ImageNet statistics expressed for [-1, 1] input.
  constexpr float shift[3] = {-0.030f, -0.088f, -0.188f};
  constexpr float scale[3] = {0.458f, 0.448f, 0.450f};
  FeatureMap res(3, image.height(), image.width());
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x) {
        const float v = image(x, y, image.channels() == 3 ? c : 0);
        res.at(c, y, x) = (2.f * v - 1.f - shift[c]) / scale[c];
      }
  return res;
}

std::array<FeatureMap, 5> alexnet_features(const LpipsWeights& w, const FeatureMap& input) {
  std::array<FeatureMap, 5> out;
  const FeatureMap* x = &input;
  FeatureMap pooled;
  for (size_t l = 0; l < kAlexConv.size(); ++l) {
    const AlexConvShape& s = kAlexConv[l];
    if (x->channels != s.in) fail("AlexNet conv", l + 1, ": ", x->channels, " input channels, expected ", s.in);
    out[l] = conv2d(*x, w.conv[l].weight.data(), w.conv[l].bias.data(), s.out, s.kernel, s.stride, s.pad);
    relu(out[l]);
    // torchvision pools after conv1 and conv2 only (its third pool follows conv5, past LPIPS's taps).
    if (l < 2) {
      pooled = max_pool_3x3_stride2(out[l]);
      x = &pooled;
    } else {
      x = &out[l];
    }
  }
  return out;
}

}  // namespace chungs
