// New map points of a monocular keyframe (issue 25): without depth, a point needs two views. The new
// keyframe's unmatched features are matched to those of its covisible keyframes along epipolar lines and
// triangulated where the two rays meet at a usable angle.
#include <Eigen/Geometry>
#include <algorithm>
#include <climits>
#include <cmath>

#include "chungs/tracking/matcher.hpp"
#include "chungs/tracking/mono_init.hpp"
#include "chungs/tracking/visual_tracker.hpp"

namespace chungs::tracking {
namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace

int VisualTracker::triangulate_new_points(long kf_id) {
  constexpr int kMaxHamming = 50;
  const double cos_min = std::cos(opt_.mono_point_parallax_deg * M_PI / 180);
  const float sf = opt_.orb.scale_factor;
  Eigen::Matrix3d K;
  K << k_.fx, 0, k_.cx, 0, k_.fy, k_.cy, 0, 0, 1;
  const Eigen::Matrix3d Ki = K.inverse();
  const SE3 T1 = map_.kf(kf_id).T_cw();
  const Eigen::Vector3d C1 = map_.kf(kf_id).T_wc.t;
  int created = 0;
  for (auto& [n_id, shared] : map_.covisible(kf_id, 1, size_t(opt_.mono_neighbours))) {
    if (map_.kf(n_id).bad) continue;
    const SE3 T2 = map_.kf(n_id).T_cw();
    const Eigen::Vector3d C2 = map_.kf(n_id).T_wc.t;
    // A baseline that is tiny against the scene depth gives points with no usable depth: skip the pair.
    std::vector<double> z;
    for (long pid : map_.kf(n_id).points)
      if (const MapPoint* p = pid >= 0 ? map_.point(pid) : nullptr) z.push_back((T2 * p->pos).z());
    if (z.empty()) continue;
    std::nth_element(z.begin(), z.begin() + long(z.size() / 2), z.end());
    if ((C1 - C2).norm() < 0.01 * z[z.size() / 2]) continue;
    // F21: x2^T F21 x1 = 0 for pixels x1 of the new keyframe and x2 of the neighbour.
    const SE3 T21 = T2 * T1.inverse();
    const Eigen::Matrix3d F21 = Ki.transpose() * skew(T21.t) * T21.q.toRotationMatrix() * Ki;
    const Keyframe& A = map_.kf(kf_id);
    const Keyframe& B = map_.kf(n_id);
    std::vector<char> taken(B.feat.size(), 0);
    for (size_t i = 0; i < A.feat.size(); ++i) {
      if (A.points[i] >= 0) continue;
      const auto& ka = A.feat.kps[i];
      const Eigen::Vector3d l = F21 * Eigen::Vector3d(ka.pt.x, ka.pt.y, 1);
      const double ln = l.head<2>().squaredNorm();
      if (ln < 1e-18) continue;
      int best = INT_MAX, second = INT_MAX, bj = -1;
      for (size_t j = 0; j < B.feat.size(); ++j) {
        if (B.points[j] >= 0 || taken[j]) continue;
        const auto& kb = B.feat.kps[j];
        if (std::abs(kb.octave - ka.octave) > 1) continue;
        // Within the 95 % band of a one-dimensional (point to line) error at the feature's pyramid level.
        const double d = l.dot(Eigen::Vector3d(kb.pt.x, kb.pt.y, 1));
        const double s = level_scale(kb.octave, sf);
        if (d * d / ln > 3.841 * s * s) continue;
        const int h = hamming(A.feat.desc.ptr<uint8_t>(int(i)), B.feat.desc.ptr<uint8_t>(int(j)));
        if (h < best) second = best, best = h, bj = int(j);
        else if (h < second) second = h;
      }
      // The epipolar line crosses many features: the best must stand out.
      if (bj < 0 || best > kMaxHamming || (second != INT_MAX && best > 0.8 * second)) continue;
      const auto& kb = B.feat.kps[size_t(bj)];
      const Eigen::Vector3d r1 = Ki * Eigen::Vector3d(ka.pt.x, ka.pt.y, 1), r2 = Ki * Eigen::Vector3d(kb.pt.x, kb.pt.y, 1);
      const Eigen::Vector3d X = triangulate(T1, T2, r1.head<2>(), r2.head<2>());
      if (!X.allFinite()) continue;
      const Eigen::Vector3d d1 = X - C1, d2 = X - C2;
      if (d1.normalized().dot(d2.normalized()) > cos_min) continue;
      const double s1 = level_scale(ka.octave, sf), s2 = level_scale(kb.octave, sf);
      if ((T1 * X).z() <= 0 || (T2 * X).z() <= 0) continue;
      if (reprojection_chi2(k_, T1.q, T1.t, X, ka.pt.x, ka.pt.y, kNoRight, 1 / s1) > kChi2Mono ||
          reprojection_chi2(k_, T2.q, T2.t, X, kb.pt.x, kb.pt.y, kNoRight, 1 / s2) > kChi2Mono)
        continue;
      // The two views must see the point at about the sizes their pyramid levels say.
      const double dist_ratio = d2.norm() / d1.norm(), level_ratio = s1 / s2;
      if (dist_ratio * 1.5 * sf < level_ratio || dist_ratio > level_ratio * 1.5 * sf) continue;
      const long pid = map_.add_point(X, kf_id, int(i));
      map_.add_observation(pid, n_id, bj);
      taken[size_t(bj)] = 1;
      recent_points_.push_back(pid);
      ++created;
    }
  }
  fuse_with_neighbours(kf_id);
  return created;
}

void VisualTracker::fuse_with_neighbours(long kf_id) {
  // Tracking matched the frame against the local map only: points of the neighbours it missed, and the new
  // points in the neighbours that saw them without a point there, are matched by projection now. A monocular
  // point needs a third view to survive culling, and these shared observations are what local BA and the
  // covisibility graph rest on.
  ProjectionSearch s;
  s.radius = 3;
  const auto neighbours = map_.covisible(kf_id, 1, size_t(opt_.mono_neighbours));
  std::vector<long> own;
  for (long pid : map_.kf(kf_id).points)
    if (pid >= 0) own.push_back(pid);
  auto fuse_into = [&](long target, const std::vector<long>& candidates) {
    Keyframe& T = map_.kf(target);
    std::vector<long> matches = T.points;
    const std::vector<long> before = matches;
    FeatureGrid grid(T.feat.kps, width_, height_);
    search_by_projection(map_, candidates, T.T_cw(), k_, width_, height_, T.feat, grid, matches, s);
    for (size_t i = 0; i < matches.size(); ++i) {
      if (matches[i] < 0 || before[i] >= 0) continue;
      const MapPoint* p = map_.point(matches[i]);
      if (p && !p->obs.count(target)) map_.add_observation(matches[i], target, int(i));
    }
  };
  std::vector<long> theirs;
  for (auto& [n, shared] : neighbours) {
    if (map_.kf(n).bad) continue;
    fuse_into(n, own);
    for (long pid : map_.kf(n).points)
      if (pid >= 0) theirs.push_back(pid);
  }
  fuse_into(kf_id, theirs);
}

}  // namespace chungs::tracking
