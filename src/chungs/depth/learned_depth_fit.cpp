// The median/MAD fit of a relative inverse-depth prediction to metric sparse depths, and the aligned
// prior the plane sweep takes (learned_depth.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "chungs/common/error.hpp"
#include "chungs/depth/learned_depth.hpp"

namespace chungs {
namespace {

// Median of a copy (even counts: the mean of the two middle values).
double median_of(std::vector<double> v) {
  const size_t n = v.size(), h = n / 2;
  std::nth_element(v.begin(), v.begin() + h, v.end());
  const double hi = v[h];
  if (n % 2) return hi;
  return 0.5 * (*std::max_element(v.begin(), v.begin() + h) + hi);
}

double mad_of(const std::vector<double>& v, double med) {
  std::vector<double> d(v.size());
  for (size_t i = 0; i < v.size(); ++i) d[i] = std::abs(v[i] - med);
  return median_of(std::move(d));
}

struct Line {
  double scale = 0, shift = 0;
  std::string refused;
};

// scale = MAD(t) / MAD(p), shift = median(t) - scale median(p): both medians map onto each other and
// so do the spreads, whatever the outliers do to a least-squares fit.
Line median_mad_line(const std::vector<double>& p, const std::vector<double>& t) {
  Line l;
  const double mp = median_of(p), mt = median_of(t);
  const double sp = mad_of(p, mp), st = mad_of(t, mt);
  // Relative to the values' size: a spread at rounding level is no spread.
  if (!(sp > 1e-12 * std::max(1.0, std::abs(mp)))) {
    l.refused = cat("the prediction does not vary over the ", p.size(), " samples (MAD ", sp,
                    "): no scale can be measured");
    return l;
  }
  if (!(st > 1e-12 * std::abs(mt))) {
    l.refused = cat("the sample depths do not vary (", p.size(), " samples, inverse-depth MAD ", st,
                    "): no scale can be measured");
    return l;
  }
  // MADs carry no sign: a prediction that falls as inverse depth rises (a depth model read as
  // inverse depth) would fit with a positive scale and be wrong everywhere.
  double cov = 0;
  for (size_t i = 0; i < p.size(); ++i) cov += (p[i] - mp) * (t[i] - mt);
  if (!(cov > 0)) {
    l.refused = cat("the prediction falls where the samples' inverse depth rises (", p.size(),
                    " samples): is the model's output depth? (metadata chungs.output: depth)");
    return l;
  }
  l.scale = st / sp;
  l.shift = mt - l.scale * mp;
  return l;
}

}  // namespace

InverseDepthFit fit_inverse_depth(const std::vector<double>& prediction, const std::vector<double>& depth,
                                  const InverseDepthFitOptions& o) {
  if (prediction.size() != depth.size())
    fail("inverse-depth fit: ", prediction.size(), " predictions but ", depth.size(), " depths");
  if (o.min_samples < 2) fail("inverse-depth fit: min_samples must be at least 2, got ", o.min_samples);
  if (!(o.outlier_mads > 0) || !std::isfinite(o.outlier_mads))
    fail("inverse-depth fit: outlier_mads must be positive, got ", o.outlier_mads);
  if (!(o.max_depth >= 0) || !std::isfinite(o.max_depth))
    fail("inverse-depth fit: max_depth must be 0 or positive, got ", o.max_depth);

  InverseDepthFit f;
  std::vector<double> p, t;
  for (size_t i = 0; i < prediction.size(); ++i)
    if (std::isfinite(prediction[i]) && std::isfinite(depth[i]) && depth[i] > 0) {
      p.push_back(prediction[i]);
      t.push_back(1.0 / depth[i]);
    }
  f.samples = p.size();
  if (f.samples < o.min_samples) {
    f.refused = cat(f.samples, " usable samples (of ", prediction.size(), "), at least ", o.min_samples, " needed");
    return f;
  }
  Line l = median_mad_line(p, t);
  if (!l.refused.empty()) {
    f.refused = l.refused;
    return f;
  }
  // Residuals of the first fit; those beyond k MADs of their median are outliers (wrong matches,
  // moving objects, the model's errors), and the same fit runs again on the rest.
  std::vector<double> r(p.size());
  for (size_t i = 0; i < p.size(); ++i) r[i] = l.scale * p[i] + l.shift - t[i];
  // The residuals' MAD has a floor: on exact data it is rounding, and rounding is no outlier.
  const double mr = median_of(r), sr = std::max(mad_of(r, mr), 1e-9 * median_of(t));
  std::vector<double> pi, ti;
  for (size_t i = 0; i < p.size(); ++i)
    if (std::abs(r[i] - mr) <= o.outlier_mads * sr) pi.push_back(p[i]), ti.push_back(t[i]);
  if (pi.size() < o.min_samples) {
    f.refused = cat("only ", pi.size(), " of ", f.samples, " samples agree with the first fit (within ",
                    o.outlier_mads, " MADs), at least ", o.min_samples, " needed");
    return f;
  }
  l = median_mad_line(pi, ti);
  if (!l.refused.empty()) {
    f.refused = "after dropping outliers, " + l.refused;
    return f;
  }
  f.scale = l.scale;
  f.shift = l.shift;
  f.inliers = pi.size();
  std::vector<double> rel(pi.size());
  for (size_t i = 0; i < pi.size(); ++i) {
    const double inv = f.scale * pi[i] + f.shift;
    rel[i] = inv > 0 ? std::abs(1.0 / inv - 1.0 / ti[i]) * ti[i] : std::numeric_limits<double>::infinity();
  }
  f.median_rel_error = median_of(std::move(rel));
  f.ok = true;
  return f;
}

AlignedDepth align_inverse_depth(const ImageF& prediction, const std::vector<DepthSample>& samples,
                                 const InverseDepthFitOptions& o) {
  if (prediction.empty() || prediction.channels() != 1)
    fail("inverse-depth alignment: the prediction must be a 1-channel image, got ", prediction.width(), "x",
         prediction.height(), "x", prediction.channels());
  const int w = prediction.width(), h = prediction.height();
  std::vector<double> p, d;
  p.reserve(samples.size());
  d.reserve(samples.size());
  for (const auto& s : samples) {
    if (!std::isfinite(s.x) || !std::isfinite(s.y)) continue;
    const long x = std::lround(s.x), y = std::lround(s.y);
    if (x < 0 || y < 0 || x >= w || y >= h) continue;
    p.push_back(prediction(int(x), int(y)));
    d.push_back(s.depth);
  }
  AlignedDepth out;
  out.fit = fit_inverse_depth(p, d, o);
  if (!out.fit.ok) {
    if (p.size() < samples.size())
      out.fit.refused += cat(" (", samples.size() - p.size(), " of ", samples.size(), " samples outside the ", w,
                             "x", h, " image)");
    return out;
  }

  // The confidence of the paper's reference code: the prediction made scale free ((p - median) / MAD
  // over the image) and exp(-|Sobel|^2 / 0.2): low along depth edges, where a relative prediction
  // blurs foreground into background.
  std::vector<double> all;
  all.reserve(prediction.pixels());
  for (float v : prediction.vec())
    if (std::isfinite(v)) all.push_back(v);
  const double med = median_of(all), mad = std::max(mad_of(all, med), 1e-12);
  auto norm = [&](int x, int y) {
    x = std::clamp(x, 0, w - 1), y = std::clamp(y, 0, h - 1);
    return (double(prediction(x, y)) - med) / mad;
  };
  out.prior.inv_depth = ImageF(w, h, 1, 0.f);
  out.prior.confidence = ImageF(w, h, 1, 0.f);
  out.depth = ImageF(w, h, 1, 0.f);
  const double min_inv = o.max_depth > 0 ? 1.0 / o.max_depth : 0.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double inv = out.fit.scale * double(prediction(x, y)) + out.fit.shift;
      if (!(inv > 0) || !std::isfinite(inv) || inv < min_inv) continue;
      const double gx = norm(x + 1, y - 1) + 2 * norm(x + 1, y) + norm(x + 1, y + 1) - norm(x - 1, y - 1) -
                        2 * norm(x - 1, y) - norm(x - 1, y + 1);
      const double gy = norm(x - 1, y + 1) + 2 * norm(x, y + 1) + norm(x + 1, y + 1) - norm(x - 1, y - 1) -
                        2 * norm(x, y - 1) - norm(x + 1, y - 1);
      const double g2 = gx * gx + gy * gy;
      out.depth(x, y) = float(1.0 / inv);
      out.prior.inv_depth(x, y) = float(inv);
      // A non-finite neighbour (no prediction there) leaves no gradient to trust: confidence 0.
      out.prior.confidence(x, y) = std::isfinite(g2) ? float(std::exp(-g2 / 0.2)) : 0.f;
    }
  return out;
}

}  // namespace chungs
