#include "chungs/tracking/mono_init.hpp"

#include <ceres/manifold.h>

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <future>
#include <opencv2/calib3d.hpp>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"

namespace chungs::tracking {

const char* model_name(TwoViewModel m) {
  switch (m) {
    case TwoViewModel::Homography: return "homography";
    case TwoViewModel::Fundamental: return "fundamental";
    case TwoViewModel::None: break;
  }
  return "none";
}

Eigen::Vector3d triangulate(const SE3& T1, const SE3& T2, const Eigen::Vector2d& x1, const Eigen::Vector2d& x2) {
  // Each view gives two rows of A X = 0 (x × (P X) = 0); the null vector of A is the point.
  Eigen::Matrix<double, 3, 4> P1, P2;
  P1 << T1.q.toRotationMatrix(), T1.t;
  P2 << T2.q.toRotationMatrix(), T2.t;
  Eigen::Matrix4d A;
  A.row(0) = x1.x() * P1.row(2) - P1.row(0);
  A.row(1) = x1.y() * P1.row(2) - P1.row(1);
  A.row(2) = x2.x() * P2.row(2) - P2.row(0);
  A.row(3) = x2.y() * P2.row(2) - P2.row(1);
  Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X[3]) < 1e-12) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  return X.head<3>() / X[3];
}

namespace {

constexpr double kChi2TwoDof = 5.991, kChi2OneDof = 3.841;

Eigen::Matrix3d to_eigen(const cv::Mat& m) {
  Eigen::Matrix3d e;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) e(r, c) = m.at<double>(r, c);
  return e;
}

// How well a homography explains the matches: both transfer errors, each inlier adding (threshold - error).
// A sum of margins rather than an inlier count, so that a model that fits its inliers tightly wins.
double score_homography(const Eigen::Matrix3d& H, const std::vector<cv::Point2f>& p1, const std::vector<cv::Point2f>& p2,
                        const std::vector<double>& inv_var) {
  const Eigen::Matrix3d Hi = H.inverse();
  double score = 0;
  for (size_t i = 0; i < p1.size(); ++i) {
    const Eigen::Vector3d a(p1[i].x, p1[i].y, 1), b(p2[i].x, p2[i].y, 1);
    const Eigen::Vector3d ab = H * a, ba = Hi * b;
    if (std::abs(ab.z()) < 1e-12 || std::abs(ba.z()) < 1e-12) continue;
    const double e2 = (ab.hnormalized() - b.head<2>()).squaredNorm() * inv_var[i];
    const double e1 = (ba.hnormalized() - a.head<2>()).squaredNorm() * inv_var[i];
    if (e1 > kChi2TwoDof || e2 > kChi2TwoDof) continue;
    score += 2 * kChi2TwoDof - e1 - e2;
  }
  return score;
}

// The same for a fundamental matrix: distances to the epipolar lines, tested with the one-dimensional threshold
// (a point-to-line error has one degree of freedom) but scored against the two-dimensional one, so that the two
// models' scores are on one scale (otherwise F, with its laxer test, would win every tie).
double score_fundamental(const Eigen::Matrix3d& F, const std::vector<cv::Point2f>& p1, const std::vector<cv::Point2f>& p2,
                         const std::vector<double>& inv_var) {
  double score = 0;
  for (size_t i = 0; i < p1.size(); ++i) {
    const Eigen::Vector3d a(p1[i].x, p1[i].y, 1), b(p2[i].x, p2[i].y, 1);
    const Eigen::Vector3d l2 = F * a, l1 = F.transpose() * b;
    const double n2 = l2.head<2>().squaredNorm(), n1 = l1.head<2>().squaredNorm();
    if (n1 < 1e-18 || n2 < 1e-18) continue;
    const double e2 = std::pow(l2.dot(b), 2) / n2 * inv_var[i], e1 = std::pow(l1.dot(a), 2) / n1 * inv_var[i];
    if (e1 > kChi2OneDof || e2 > kChi2OneDof) continue;
    score += 2 * kChi2TwoDof - e1 - e2;
  }
  return score;
}

struct Hypothesis {
  SE3 T_21;
  int good = 0;                           // in front of both cameras, small reprojection error
  std::vector<int> kept;                  // good and with enough parallax
  std::vector<Eigen::Vector3d> points;    // of `kept`, first camera's frame
  std::vector<double> parallax_deg;       // of `kept`
};

Hypothesis evaluate(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const std::vector<cv::Point2f>& p1,
                    const std::vector<cv::Point2f>& p2, const std::vector<char>& inlier,
                    const std::vector<double>& inv_var, const Intrinsics& k, double min_parallax_deg) {
  Hypothesis h;
  h.T_21 = SE3(Eigen::Quaterniond(R).normalized(), t.normalized());
  const SE3 I;
  const Eigen::Vector3d C2 = h.T_21.inverse().t;
  const double cos_min = std::cos(min_parallax_deg * M_PI / 180);
  auto reproj = [&](const Eigen::Vector3d& pc, const cv::Point2f& px) {
    return std::pow(k.fx * pc.x() / pc.z() + k.cx - px.x, 2) + std::pow(k.fy * pc.y() / pc.z() + k.cy - px.y, 2);
  };
  for (size_t i = 0; i < p1.size(); ++i) {
    if (!inlier[i]) continue;
    const Eigen::Vector2d x1((p1[i].x - k.cx) / k.fx, (p1[i].y - k.cy) / k.fy);
    const Eigen::Vector2d x2((p2[i].x - k.cx) / k.fx, (p2[i].y - k.cy) / k.fy);
    const Eigen::Vector3d X = triangulate(I, h.T_21, x1, x2);
    if (!X.allFinite()) continue;
    const Eigen::Vector3d X2 = h.T_21 * X;
    if (X.z() <= 0 || X2.z() <= 0) continue;
    if (reproj(X, p1[i]) * inv_var[i] > kChi2TwoDof || reproj(X2, p2[i]) * inv_var[i] > kChi2TwoDof) continue;
    ++h.good;
    const double cos_par = X.normalized().dot((X - C2).normalized());
    if (cos_par > cos_min) continue;
    h.kept.push_back(int(i));
    h.points.push_back(X);
    h.parallax_deg.push_back(std::acos(std::clamp(cos_par, -1.0, 1.0)) * 180 / M_PI);
  }
  return h;
}

}  // namespace

TwoViewResult two_view_geometry(const std::vector<cv::Point2f>& p1, const std::vector<cv::Point2f>& p2,
                                const std::vector<int>& octave, const Intrinsics& k, const TwoViewOptions& opt) {
  TwoViewResult res;
  if (p1.size() != p2.size()) fail("two-view initialisation: ", p1.size(), " points in view 1 but ", p2.size(), " in view 2");
  if (!octave.empty() && octave.size() != p1.size())
    fail("two-view initialisation: ", octave.size(), " pyramid levels for ", p1.size(), " matches");
  res.matches = int(p1.size());
  if (res.matches < std::max(opt.min_matches, 8)) {
    res.why = cat(res.matches, " matches, ", opt.min_matches, " needed");
    return res;
  }
  std::vector<double> inv_var(p1.size());
  for (size_t i = 0; i < p1.size(); ++i) {
    const double s = octave.empty() ? 1.0 : level_scale(octave[i], opt.scale_factor);
    inv_var[i] = 1.0 / (s * s);
  }
  // Both models at once: neither result is needed to fit the other, and together they decide which applies.
  // Thresholds are the 95 % chi-square bounds for a one-pixel error (2 and 1 degrees of freedom).
  auto fit_h = std::async(std::launch::async, [&] {
    cv::Mat mask;
    cv::Mat H = cv::findHomography(p1, p2, cv::RANSAC, std::sqrt(kChi2TwoDof), mask, 2000, 0.999);
    return std::make_pair(H, mask);
  });
  cv::Mat mask_f;
  cv::Mat F = cv::findFundamentalMat(p1, p2, cv::FM_RANSAC, std::sqrt(kChi2OneDof), 0.999, 2000, mask_f);
  if (F.rows == 3 && F.cols == 3) {
    // RANSAC's F comes from a minimal sample and is too coarse to triangulate from: refit it to all its
    // inliers (normalised eight-point, least squares).
    std::vector<cv::Point2f> i1, i2;
    for (size_t i = 0; i < p1.size(); ++i)
      if (mask_f.at<uchar>(int(i))) i1.push_back(p1[i]), i2.push_back(p2[i]);
    if (i1.size() >= 8) {
      cv::Mat refined = cv::findFundamentalMat(i1, i2, cv::FM_8POINT);
      if (refined.rows == 3 && refined.cols == 3) F = refined;
    }
  }
  auto [H, mask_h] = fit_h.get();
  const bool have_h = H.rows == 3 && H.cols == 3, have_f = F.rows == 3 && F.cols == 3;
  if (!have_h && !have_f) {
    res.why = "neither a homography nor a fundamental matrix could be fitted";
    return res;
  }
  const Eigen::Matrix3d He = have_h ? to_eigen(H) : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d Fe = have_f ? to_eigen(F) : Eigen::Matrix3d::Zero();
  res.score_h = have_h ? score_homography(He, p1, p2, inv_var) : 0;
  res.score_f = have_f ? score_fundamental(Fe, p1, p2, inv_var) : 0;
  // Model selection. A planar scene (or a camera that only rotated) fits a homography exactly, and then a
  // whole family of fundamental matrices fits as well: the one RANSAC returns carries a motion picked by
  // noise. A general 3D scene with enough parallax fits no single homography. The score ratio tells the
  // two apart; the bias towards the homography below one half is because F also fits planar data well, so
  // a near tie means "planar".
  const double total = res.score_h + res.score_f;
  if (!(total > 0)) {
    res.why = "no model explains the matches";
    return res;
  }
  res.model = res.score_h / total > opt.homography_ratio ? TwoViewModel::Homography : TwoViewModel::Fundamental;

  const cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::vector<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> motions;
  std::vector<char> inlier(p1.size(), 0);
  if (res.model == TwoViewModel::Homography) {
    std::vector<cv::Mat> Rs, ts, ns;
    cv::decomposeHomographyMat(H, K, Rs, ts, ns);
    // Of the (up to four) decompositions, those that put the plane behind the points it carries go first.
    std::vector<cv::Point2f> i1, i2;
    for (size_t i = 0; i < p1.size(); ++i)
      if (mask_h.at<uchar>(int(i))) i1.push_back(p1[i]), i2.push_back(p2[i]);
    std::vector<cv::Point2f> n1, n2;
    cv::undistortPoints(i1, n1, K, cv::noArray());
    cv::undistortPoints(i2, n2, K, cv::noArray());
    std::vector<int> visible;
    cv::filterHomographyDecompByVisibleRefpoints(Rs, ns, n1, n2, visible);
    if (!visible.empty()) {
      std::vector<cv::Mat> r2, t2;
      for (int v : visible) r2.push_back(Rs[size_t(v)]), t2.push_back(ts[size_t(v)]);
      Rs = r2, ts = t2;
    }
    for (size_t i = 0; i < Rs.size(); ++i)
      motions.emplace_back(to_eigen(Rs[i]), Eigen::Vector3d(ts[i].at<double>(0), ts[i].at<double>(1), ts[i].at<double>(2)));
    for (size_t i = 0; i < p1.size(); ++i) inlier[i] = mask_h.at<uchar>(int(i)) != 0;
  } else {
    const cv::Mat E = K.t() * F * K;
    cv::Mat R1, R2, t;
    cv::decomposeEssentialMat(E, R1, R2, t);
    const Eigen::Vector3d te(t.at<double>(0), t.at<double>(1), t.at<double>(2));
    for (const cv::Mat& R : {R1, R2})
      for (double sign : {1.0, -1.0}) motions.emplace_back(to_eigen(R), sign * te);
    for (size_t i = 0; i < p1.size(); ++i) inlier[i] = mask_f.at<uchar>(int(i)) != 0;
  }
  // Every decomposition leaves several motions; the true one puts the most points in front of both cameras.
  std::vector<Hypothesis> hyps;
  for (auto& [R, t] : motions) {
    if (!(t.norm() > 1e-9)) continue;  // a pure rotation has no baseline to triangulate from
    hyps.push_back(evaluate(R, t, p1, p2, inlier, inv_var, k, opt.min_parallax_deg));
  }
  std::sort(hyps.begin(), hyps.end(), [](const Hypothesis& a, const Hypothesis& b) { return a.good > b.good; });
  if (log::enabled(log::Level::Debug)) {
    std::string counts;
    for (auto& h : hyps) counts += cat(" ", h.good, "/", h.kept.size());
    log::debug("two-view: ", model_name(res.model), " (S_H ", res.score_h, ", S_F ", res.score_f,
               "); points in front / with parallax per motion:", counts);
  }
  if (hyps.empty() || hyps[0].good == 0) {
    res.why = cat("no motion hypothesis of the ", model_name(res.model), " puts points in front of both cameras");
    return res;
  }
  if (hyps.size() > 1 && hyps[1].good >= opt.ambiguity * hyps[0].good) {
    res.why = cat("ambiguous ", model_name(res.model), ": two motions explain ", hyps[0].good, " and ", hyps[1].good, " points");
    return res;
  }
  Hypothesis& best = hyps[0];
  if (int(best.kept.size()) < opt.min_points) {
    res.why = cat(best.kept.size(), " points with ", opt.min_parallax_deg, " deg of parallax (", best.good,
                  " triangulated), ", opt.min_points, " needed");
    return res;
  }

  // Two-view bundle adjustment: the first camera holds the gauge, the second and the points move.
  std::array<double, 4> q0 = {0, 0, 0, 1};
  std::array<double, 3> t0 = {0, 0, 0};
  std::array<double, 4> q2 = {best.T_21.q.x(), best.T_21.q.y(), best.T_21.q.z(), best.T_21.q.w()};
  std::array<double, 3> t2 = {best.T_21.t.x(), best.T_21.t.y(), best.T_21.t.z()};
  std::vector<std::array<double, 3>> X(best.points.size());
  for (size_t i = 0; i < X.size(); ++i) X[i] = {best.points[i].x(), best.points[i].y(), best.points[i].z()};
  ceres::Problem::Options popt;
  popt.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(popt);
  ceres::EigenQuaternionManifold qman;
  problem.AddParameterBlock(q0.data(), 4, &qman);
  problem.AddParameterBlock(t0.data(), 3);
  problem.AddParameterBlock(q2.data(), 4, &qman);
  problem.AddParameterBlock(t2.data(), 3);
  problem.SetParameterBlockConstant(q0.data());
  problem.SetParameterBlockConstant(t0.data());
  for (size_t j = 0; j < X.size(); ++j) {
    const int i = best.kept[j];
    const double w = std::sqrt(inv_var[i]);
    problem.AddResidualBlock(ReprojectionCost::create(k, p1[i].x, p1[i].y, kNoRight, w),
                             new ceres::HuberLoss(std::sqrt(kChi2TwoDof)), q0.data(), t0.data(), X[j].data());
    problem.AddResidualBlock(ReprojectionCost::create(k, p2[i].x, p2[i].y, kNoRight, w),
                             new ceres::HuberLoss(std::sqrt(kChi2TwoDof)), q2.data(), t2.data(), X[j].data());
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = opt.ba_iterations;
  so.num_threads = 2;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  const SE3 T21(Eigen::Quaterniond(q2[3], q2[0], q2[1], q2[2]).normalized(), Eigen::Vector3d(t2[0], t2[1], t2[2]));

  // Points the refined geometry no longer explains are dropped.
  std::vector<double> depths, parallax;
  const Eigen::Vector3d C2 = T21.inverse().t;
  for (size_t j = 0; j < X.size(); ++j) {
    const int i = best.kept[j];
    const Eigen::Vector3d P(X[j][0], X[j][1], X[j][2]);
    const SE3 I;
    if (!P.allFinite() || reprojection_chi2(k, I.q, I.t, P, p1[i].x, p1[i].y, kNoRight, std::sqrt(inv_var[i])) > kChi2TwoDof ||
        reprojection_chi2(k, T21.q, T21.t, P, p2[i].x, p2[i].y, kNoRight, std::sqrt(inv_var[i])) > kChi2TwoDof)
      continue;
    res.used.push_back(i);
    res.points.push_back(P);
    depths.push_back(P.z());
    parallax.push_back(std::acos(std::clamp(P.normalized().dot((P - C2).normalized()), -1.0, 1.0)) * 180 / M_PI);
  }
  if (int(res.used.size()) < opt.min_points) {
    res.why = cat(res.used.size(), " points left after bundle adjustment, ", opt.min_points, " needed");
    res.used.clear();
    res.points.clear();
    return res;
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double med = median(depths);
  if (!(med > 0) || !(T21.t.norm() > 1e-9 * med)) {
    res.why = "degenerate geometry after bundle adjustment";
    res.used.clear();
    res.points.clear();
    return res;
  }
  // The scale convention (see the header): median depth of the first view = target.
  res.scale = opt.target_median_depth / med;
  for (auto& P : res.points) P *= res.scale;
  res.T_21 = SE3(T21.q, T21.t * res.scale);
  res.median_parallax_deg = median(parallax);
  res.ok = true;
  return res;
}

std::vector<std::pair<int, int>> match_for_init(const Features& a, const Features& b, int width, int height,
                                                const TwoViewOptions& opt) {
  FeatureGrid grid(b.kps, width, height);
  const float radius = opt.search_radius * float(width);
  std::vector<int> best_for_b(b.size(), -1), dist_for_b(b.size(), INT_MAX);
  std::vector<int> near;
  for (size_t i = 0; i < a.size(); ++i) {
    const auto& kp = a.kps[i];
    // A feature keeps about its scale over a small motion: neighbouring pyramid levels only.
    grid.query(kp.pt.x, kp.pt.y, radius, near, std::max(0, kp.octave - 1), kp.octave + 1);
    int best = INT_MAX, second = INT_MAX, bj = -1;
    for (int j : near) {
      const int d = hamming(a.desc.ptr<uint8_t>(int(i)), b.desc.ptr<uint8_t>(j));
      if (d < best) second = best, best = d, bj = j;
      else if (d < second) second = d;
    }
    if (bj < 0 || best > 50 || (second != INT_MAX && best > 0.9 * second)) continue;
    if (best < dist_for_b[bj]) dist_for_b[bj] = best, best_for_b[bj] = int(i);
  }
  std::vector<std::pair<int, int>> out;
  for (size_t j = 0; j < b.size(); ++j)
    if (best_for_b[j] >= 0) out.emplace_back(best_for_b[j], int(j));
  std::sort(out.begin(), out.end());
  return out;
}

TwoViewResult initialize_two_view(const Features& a, const Features& b, const Intrinsics& k, int width, int height,
                                  std::vector<std::pair<int, int>>& pairs, const TwoViewOptions& opt) {
  pairs = match_for_init(a, b, width, height, opt);
  std::vector<cv::Point2f> p1, p2;
  std::vector<int> oct;
  for (auto& [i, j] : pairs) {
    p1.push_back(a.kps[i].pt);
    p2.push_back(b.kps[j].pt);
    oct.push_back(std::max(a.kps[i].octave, b.kps[j].octave));
  }
  return two_view_geometry(p1, p2, oct, k, opt);
}

}  // namespace chungs::tracking
