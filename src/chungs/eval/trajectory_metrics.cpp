#include "chungs/eval/trajectory_metrics.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numeric>

#include "chungs/common/error.hpp"
#include "chungs/geometry/umeyama.hpp"

namespace chungs {

Alignment parse_alignment(const std::string& name) {
  std::string s = name;
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (s == "none") return Alignment::None;
  if (s == "se3") return Alignment::SE3;
  if (s == "sim3") return Alignment::Sim3;
  fail("unknown alignment '", name, "' (expected none, se3 or sim3)");
}

const char* alignment_name(Alignment a) {
  switch (a) {
    case Alignment::None: return "none";
    case Alignment::SE3: return "se3";
    case Alignment::Sim3: return "sim3";
  }
  return "?";
}

ErrorStats error_stats(std::vector<double> e) {
  if (e.empty()) fail("error statistics of an empty list");
  ErrorStats s;
  s.count = e.size();
  const double n = double(e.size());
  double sum = 0, sq = 0;
  for (double v : e) sum += v, sq += v * v;
  s.mean = sum / n;
  s.rmse = std::sqrt(sq / n);
  double var = 0;
  for (double v : e) var += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(var / n);
  std::sort(e.begin(), e.end());
  s.min = e.front();
  s.max = e.back();
  const size_t m = e.size() / 2;
  s.median = e.size() % 2 ? e[m] : 0.5 * (e[m - 1] + e[m]);
  return s;
}

namespace {

std::string describe(const Trajectory& t) {
  if (t.empty()) return "0 poses";
  auto [lo, hi] = std::minmax_element(t.stamps.begin(), t.stamps.end());
  return cat(t.size(), " poses, stamps ", *lo, "..", *hi, " s");
}

}  // namespace

AteResult compute_ate(const Trajectory& gt, const Trajectory& est, const AteOptions& opt) {
  if (!(opt.max_dt >= 0.0)) fail("ATE: max_dt must be >= 0, got ", opt.max_dt);
  AteResult r;
  r.align = opt.align;
  r.pairs = associate_stamps(gt.stamps, est.stamps, opt.max_dt);
  if (r.pairs.size() < 3)
    fail("ATE: only ", r.pairs.size(), " poses matched within ", opt.max_dt, " s (ground truth: ", describe(gt),
         "; estimate: ", describe(est), "); need at least 3");
  std::vector<Eigen::Vector3d> p_gt, p_est;
  p_gt.reserve(r.pairs.size());
  p_est.reserve(r.pairs.size());
  for (auto [i, j] : r.pairs) {
    p_gt.push_back(gt.poses[i].t);
    p_est.push_back(est.poses[j].t);
  }
  if (opt.align != Alignment::None) r.alignment = umeyama_align(p_est, p_gt, opt.align == Alignment::Sim3);
  r.errors.resize(r.pairs.size());
  for (size_t k = 0; k < r.pairs.size(); ++k) r.errors[k] = (p_gt[k] - r.alignment * p_est[k]).norm();
  r.stats = error_stats(r.errors);
  return r;
}

RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est, const AteResult& ate, int delta) {
  const size_t n = ate.pairs.size();
  if (delta < 1 || size_t(delta) >= n)
    fail("RPE: frame delta ", delta, " needs 1 <= delta < matched poses (", n, ")");
  std::vector<double> te, re;
  te.reserve(n - delta);
  re.reserve(n - delta);
  for (size_t k = 0; k + delta < n; ++k) {
    const auto [gi, ei] = ate.pairs[k];
    const auto [gj, ej] = ate.pairs[k + delta];
    const SE3 dq = gt.poses[gi].inverse() * gt.poses[gj];
    const SE3 dp = ate.alignment.apply(est.poses[ei]).inverse() * ate.alignment.apply(est.poses[ej]);
    const SE3 e = dq.inverse() * dp;
    te.push_back(e.t.norm());
    // atan2 form: acos(w) loses half the digits near zero, where good estimates live.
    re.push_back(2.0 * std::atan2(e.q.vec().norm(), std::abs(e.q.w())) * 180.0 / M_PI);
  }
  RpeResult r;
  r.delta = delta;
  r.trans = error_stats(std::move(te));
  r.rot_deg = error_stats(std::move(re));
  return r;
}

RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est, const AteOptions& opt, int delta) {
  return compute_rpe(gt, est, compute_ate(gt, est, opt), delta);
}

}  // namespace chungs
