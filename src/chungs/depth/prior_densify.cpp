#include "chungs/depth/prior_densify.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

void DensifyConfig::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (scales < 1 || scales > 10) fail("densify: scales ", scales, " (1 to 10)");
  if (!positive(sigma_px) || sigma_px > 64) fail("densify: sigma_px ", sigma_px, " (0 to 64)");
  if (!positive(scale_support)) fail("densify: scale_support ", scale_support);
  if (radius < 1 || radius > 32) fail("densify: radius ", radius, " (1 to 32)");
  if (!positive(sigma_space) || !positive(sigma_color)) fail("densify: sigma_space ", sigma_space, ", sigma_color ", sigma_color);
  if (iterations < 0 || iterations > 50) fail("densify: iterations ", iterations, " (0 to 50)");
  if (!positive(support)) fail("densify: support ", support);
}

namespace {

cv::Mat wrap(ImageF& img) { return cv::Mat(img.height(), img.width(), CV_32F, img.data()); }

// Gaussian of standard deviation sigma, zero outside the image: normalized convolution divides the
// blurred values by the blurred weights, so the border needs no special case.
ImageF blur(const ImageF& in, double sigma) {
  ImageF out(in.width(), in.height(), 1);
  ImageF src = in;
  const int k = 2 * int(std::ceil(3 * sigma)) + 1;
  cv::GaussianBlur(wrap(src), wrap(out), cv::Size(k, k), sigma, sigma, cv::BORDER_CONSTANT);
  return out;
}

struct Filtered {
  ImageF value, mass;  // certainty-weighted mean, and the certainty mass under the weights
};

// One pass of the joint bilateral filter on (value, certainty): weights of distance and of the guide's
// gray-level difference, times each neighbour's certainty.
Filtered joint_bilateral(const Image8& guide, const ImageF& value, const ImageF& certainty, const DensifyConfig& c) {
  const int w = guide.width(), h = guide.height(), r = c.radius, side = 2 * r + 1;
  std::vector<float> space(size_t(side * side)), range(256);
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      space[size_t((dy + r) * side + dx + r)] = float(std::exp(-(dx * dx + dy * dy) / (2 * c.sigma_space * c.sigma_space)));
  for (int d = 0; d < 256; ++d) range[size_t(d)] = float(std::exp(-(d * d) / (2 * c.sigma_color * c.sigma_color)));
  Filtered out{ImageF(w, h, 1, 0.0f), ImageF(w, h, 1, 0.0f)};
#pragma omp parallel for schedule(dynamic, 8)
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int g = guide(x, y);
      double sv = 0, sc = 0;
      for (int dy = std::max(-r, -y); dy <= std::min(r, h - 1 - y); ++dy)
        for (int dx = std::max(-r, -x); dx <= std::min(r, w - 1 - x); ++dx) {
          const float cq = certainty(x + dx, y + dy);
          if (cq <= 0) continue;
          const double wq = double(space[size_t((dy + r) * side + dx + r)]) *
                            range[size_t(std::abs(g - guide(x + dx, y + dy)))] * cq;
          sv += wq * value(x + dx, y + dy), sc += wq;
        }
      if (sc > 0) out.value(x, y) = float(sv / sc), out.mass(x, y) = float(sc);
    }
  return out;
}

}  // namespace

DensePrior densify_prior(const Image8& image, const std::vector<DepthSample>& samples, const DensifyConfig& c) {
  c.validate();
  if (image.empty()) fail("densify: no guide image");
  const Image8 guide = to_gray(image);
  const int w = guide.width(), h = guide.height();
  // Splat: each sample on its nearest pixel, several on one pixel averaged by weight.
  ImageF wsum(w, h, 1, 0.0f), vsum(w, h, 1, 0.0f);
  for (size_t i = 0; i < samples.size(); ++i) {
    const DepthSample& s = samples[i];
    if (!std::isfinite(s.x) || !std::isfinite(s.y)) fail("densify: sample ", i, " at a non-finite pixel");
    if (!(std::isfinite(s.depth) && s.depth > 0)) fail("densify: sample ", i, " has depth ", s.depth);
    if (!(std::isfinite(s.weight) && s.weight > 0)) fail("densify: sample ", i, " has weight ", s.weight);
    const long px = std::lround(s.x), py = std::lround(s.y);
    if (px < 0 || py < 0 || px >= w || py >= h) continue;
    wsum(int(px), int(py)) += s.weight;
    vsum(int(px), int(py)) += s.weight / s.depth;
  }

  // Normalized convolution, coarse to fine: each finer scale takes over where it has support.
  ImageF fill(w, h, 1, 0.0f), fill_conf(w, h, 1, 0.0f);
  for (int l = c.scales - 1; l >= 0; --l) {
    const double sigma = c.sigma_px * std::pow(2.0, l);
    const ImageF bw = blur(wsum, sigma), bv = blur(vsum, sigma);
    // The weight a single sample leaves at its own pixel at this scale, for a scale-free threshold.
    const double peak = 1.0 / (2 * M_PI * sigma * sigma);
    const float trust = float(std::pow(0.5, l));
    for (size_t i = 0; i < fill.pixels(); ++i) {
      if (!(bw.vec()[i] > 1e-12f * float(peak))) continue;
      const float alpha = float(std::min(1.0, bw.vec()[i] / (c.scale_support * peak)));
      const float v = bv.vec()[i] / bw.vec()[i];
      fill.vec()[i] = fill.vec()[i] > 0 ? alpha * v + (1 - alpha) * fill.vec()[i] : v;
      fill_conf.vec()[i] = std::max(fill_conf.vec()[i], alpha * trust);
    }
  }

  // Edge-aware: the samples at full certainty, the fill weakly, filtered a few times with the image
  // as the guide; sample pixels keep their own value, so they are never smoothed away.
  ImageF value = fill, certainty(w, h, 1, 0.0f);
  constexpr float kFillWeight = 0.002f;  // a fill value counts for 1/500 of a sample: it only bridges gaps
  for (size_t i = 0; i < value.pixels(); ++i) {
    certainty.vec()[i] = wsum.vec()[i] > 0 ? wsum.vec()[i] : kFillWeight * fill_conf.vec()[i];
    if (wsum.vec()[i] > 0) value.vec()[i] = vsum.vec()[i] / wsum.vec()[i];
  }
  ImageF sample_only = wsum;
  // How much sample weight a pixel sees on its own surface: the confidence's measure, and the trust
  // a value carried there deserves in the next pass.
  const ImageF sample_mass = joint_bilateral(guide, value, sample_only, c).mass;
  for (int it = 0; it < c.iterations; ++it) {
    const Filtered f = joint_bilateral(guide, value, certainty, c);
    for (size_t i = 0; i < value.pixels(); ++i)
      if (f.mass.vec()[i] > 0 && wsum.vec()[i] <= 0) {
        value.vec()[i] = f.value.vec()[i];
        const float m = sample_mass.vec()[i];
        certainty.vec()[i] = std::max(certainty.vec()[i], 0.25f * m / (m + float(c.support)));
      }
  }

  DensePrior out{ImageF(w, h, 1, 0.0f), ImageF(w, h, 1, 0.0f)};
  for (size_t i = 0; i < value.pixels(); ++i) {
    if (!(value.vec()[i] > 0)) continue;
    out.inv_depth.vec()[i] = value.vec()[i];
    const float m = sample_mass.vec()[i];
    out.confidence.vec()[i] = std::max(m / (m + float(c.support)), 0.3f * fill_conf.vec()[i]);
  }
  return out;
}

}  // namespace chungs
