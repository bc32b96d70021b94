#include "chungs/eval/depth_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "chungs/common/error.hpp"
#include "chungs/image/image_io.hpp"

namespace chungs {

namespace {
bool valid(double d) { return std::isfinite(d) && d > 0; }
}  // namespace

void DepthErrorSum::add(double gt, double est) {
  if (!valid(gt)) return;
  ++gt_valid_;
  if (!valid(est)) return;
  ++pixels_;
  const double diff = est - gt;
  abs_rel_ += std::abs(diff) / gt;
  sq_ += diff * diff;
  inliers_ += std::max(est / gt, gt / est) < 1.25;
}

void DepthErrorSum::add(const ImageF& gt, const ImageF& est, const Image8* mask, const std::string& what) {
  if (gt.channels() != 1 || est.channels() != 1)
    fail(what, ": depth images need 1 channel (ground truth ", gt.channels(), ", estimate ", est.channels(), ")");
  if (!gt.same_size(est))
    fail(what, ": ground truth is ", gt.width(), "x", gt.height(), ", the estimate ", est.width(), "x", est.height());
  if (mask && (!mask->same_size(gt) || mask->channels() != 1))
    fail(what, ": the mask is ", mask->width(), "x", mask->height(), "x", mask->channels(), ", the depth ",
         gt.width(), "x", gt.height(), "x1");
  for (size_t i = 0; i < gt.pixels(); ++i)
    if (!mask || mask->vec()[i]) add(double(gt.vec()[i]), double(est.vec()[i]));
}

DepthMetrics DepthErrorSum::result() const {
  DepthMetrics m;
  m.pixels = pixels_, m.gt_valid = gt_valid_;
  const double nan = std::numeric_limits<double>::quiet_NaN(), n = double(pixels_);
  m.abs_rel = pixels_ ? abs_rel_ / n : nan;
  m.delta1 = pixels_ ? double(inliers_) / n : nan;
  m.rmse = pixels_ ? std::sqrt(sq_ / n) : nan;
  return m;
}

DepthMetrics compare_depth(const ImageF& gt, const ImageF& est, const Image8* mask) {
  DepthErrorSum s;
  s.add(gt, est, mask);
  return s.result();
}

ImageF read_depth_png(const std::filesystem::path& file, double scale) {
  if (!(std::isfinite(scale) && scale > 0)) fail(file.string(), ": depth scale ", scale, " (must be positive)");
  const Image16 raw = read_png16(file);  // names the file when it is no 1-channel 16-bit PNG
  ImageF out(raw.width(), raw.height(), 1, 0.0f);
  for (size_t i = 0; i < raw.size(); ++i) out.vec()[i] = float(double(raw.vec()[i]) / scale);
  return out;
}

DepthSetResult evaluate_depth_pairs(const std::vector<ImagePair>& pairs, double gt_scale, double est_scale) {
  if (pairs.empty()) fail("depth evaluation: no image pairs");
  DepthSetResult r;
  DepthErrorSum pooled;
  for (const ImagePair& p : pairs) {
    const ImageF gt = read_depth_png(p.ref, gt_scale), est = read_depth_png(p.test, est_scale);
    DepthErrorSum one;
    const std::string what = p.test.string() + " against " + p.ref.string();
    one.add(gt, est, nullptr, what);
    pooled.add(gt, est, nullptr, what);
    r.images.push_back({p, one.result()});
  }
  r.pooled = pooled.result();
  return r;
}

}  // namespace chungs
