#include "chungs/eval/lpips.hpp"

#include "chungs/common/error.hpp"
#include "chungs/eval/alexnet_features.hpp"

namespace chungs {

Lpips::Lpips(LpipsWeights weights, std::string source) : w_(std::move(weights)), source_(std::move(source)) {
  for (size_t l = 0; l < kAlexConv.size(); ++l) {
    const AlexConvShape& s = kAlexConv[l];
    if (w_.conv[l].weight.size() != size_t(s.out) * s.in * s.kernel * s.kernel || w_.conv[l].bias.size() != size_t(s.out) ||
        w_.lin[l].size() != size_t(s.out))
      fail(source_, ": layer ", l + 1, " has the wrong number of weights for AlexNet");
    for (float v : w_.lin[l])
      if (!(v >= 0)) fail(source_, ": lin", l, " has a negative or NaN weight (LPIPS heads are non-negative)");
  }
}

Lpips Lpips::load(const std::filesystem::path& file) { return Lpips(read_lpips_weights(file), file.string()); }

std::array<double, 5> Lpips::layer_distances(const ImageF& a, const ImageF& b) const {
  if (!a.same_shape(b))
    fail("LPIPS: images differ in shape: ", a.width(), "x", a.height(), "x", a.channels(), " vs ", b.width(), "x",
         b.height(), "x", b.channels());
  const auto fa = alexnet_features(w_, lpips_input(a));
  const auto fb = alexnet_features(w_, lpips_input(b));
  std::array<double, 5> d{};
  for (size_t l = 0; l < fa.size(); ++l) {
    const FeatureMap na = normalize_channels(fa[l]), nb = normalize_channels(fb[l]);
    const size_t n = na.plane();
    const std::vector<float>& lin = w_.lin[l];
    // Per-row sums added in row order: the same images give the same bits on any thread count.
    std::vector<double> rows(size_t(na.height), 0.0);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < na.height; ++y) {
      double s = 0;
      for (int c = 0; c < na.channels; ++c) {
        const float* pa = na.data.data() + c * n + size_t(y) * na.width;
        const float* pb = nb.data.data() + c * n + size_t(y) * na.width;
        double sc = 0;
        for (int x = 0; x < na.width; ++x) {
          const double diff = double(pa[x]) - double(pb[x]);
          sc += diff * diff;
        }
        s += lin[c] * sc;
      }
      rows[size_t(y)] = s;
    }
    double sum = 0;
    for (double r : rows) sum += r;
    d[l] = sum / double(n);
  }
  return d;
}

double Lpips::distance(const ImageF& a, const ImageF& b) const {
  double sum = 0;
  for (double v : layer_distances(a, b)) sum += v;
  return sum;
}

LpipsSetting lpips_setting(const std::filesystem::path& weights, const std::string& flag) {
  LpipsSetting s;
  if (weights.empty()) {
    s.unavailable = "no " + flag + " given";
    return s;
  }
  try {
    s.metric.emplace(Lpips::load(weights));
  } catch (const Error& e) {
    fail(flag, ": ", e.what());
  }
  return s;
}

}  // namespace chungs
