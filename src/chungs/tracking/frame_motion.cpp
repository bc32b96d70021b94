#include "chungs/tracking/frame_motion.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <climits>
#include <cmath>
#include <random>
#include <set>

#include "chungs/tracking/pose_optimizer.hpp"

namespace chungs::tracking {
namespace {

struct Pair {
  int p, c;            // feature in the previous / current frame
  Eigen::Vector3d X;   // previous camera coordinates
  PoseObservation obs; // in the current frame (X as the "world" point)
};

Eigen::Vector3d unproject(const Features& f, int i, const Intrinsics& k) {
  const double z = f.depth[i];
  const auto& kp = f.kps[i];
  return {(kp.pt.x - k.cx) / k.fx * z, (kp.pt.y - k.cy) / k.fy * z, z};
}

// Mutual best descriptor matches within a window, with a ratio test; features with depth only.
std::vector<std::pair<int, int>> match_frames(const Features& prev, const Features& cur, int width, int height,
                                              float radius) {
  FeatureGrid grid(prev.kps, width, height);
  std::vector<int> best_for_prev(prev.size(), -1), best_dist_prev(prev.size(), INT_MAX);
  std::vector<std::pair<int, int>> cand;
  std::vector<int> near;
  for (size_t i = 0; i < cur.size(); ++i) {
    if (!cur.has_depth(i)) continue;
    grid.query(cur.kps[i].pt.x, cur.kps[i].pt.y, radius, near);
    int best = INT_MAX, second = INT_MAX, bj = -1;
    for (int j : near) {
      if (!prev.has_depth(j)) continue;
      const int d = hamming(cur.desc.ptr<uint8_t>(int(i)), prev.desc.ptr<uint8_t>(j));
      if (d < best) second = best, best = d, bj = j;
      else if (d < second) second = d;
    }
    if (bj < 0 || best > 64 || best > 0.8 * second) continue;
    cand.emplace_back(int(i), bj);
    if (best < best_dist_prev[bj]) best_dist_prev[bj] = best, best_for_prev[bj] = int(i);
  }
  std::vector<std::pair<int, int>> out;
  for (auto& [i, j] : cand)
    if (best_for_prev[j] == i) out.emplace_back(j, i);
  return out;
}

bool fits(const Intrinsics& k, const SE3& T, const Pair& m) {
  return reprojection_chi2(k, T.q, T.t, m.X, m.obs.u, m.obs.v, m.obs.ur, m.obs.inv_sigma) <=
         (has_right(m.obs.ur) ? kChi2Stereo : kChi2Mono);
}

double angle_deg(const SE3& a, const SE3& b) { return a.q.angularDistance(b.q) * 180.0 / M_PI; }

}  // namespace

FrameMotion estimate_frame_motion(const Features& prev, const Features& cur, const Intrinsics& k, int width,
                                  int height, const FrameMotionOptions& opt, const SE3* predicted) {
  FrameMotion out;
  out.moving.assign(cur.size(), 0);
  const auto pairs = match_frames(prev, cur, width, height, opt.search_radius * float(width));
  out.matches = int(pairs.size());
  if (out.matches < opt.min_inliers) return out;
  std::vector<Pair> m;
  m.reserve(pairs.size());
  for (auto& [p, c] : pairs) {
    Pair q;
    q.p = p, q.c = c;
    q.X = unproject(prev, p, k);
    const auto& kp = cur.kps[c];
    q.obs = {q.X, kp.pt.x, kp.pt.y, cur.u_right[c], 1.0 / level_scale(kp.octave)};
    m.push_back(q);
  }
  // Near points have precise depth: minimal samples come from them when there are enough.
  const double near = 40 * k.bf / k.fx;
  auto cell_of = [&](const Pair& q) {
    const auto& kp = cur.kps[q.c];
    const int gx = std::clamp(int(kp.pt.x * opt.grid_cols / width), 0, opt.grid_cols - 1);
    const int gy = std::clamp(int(kp.pt.y * opt.grid_rows / height), 0, opt.grid_rows - 1);
    const double z = cur.depth[q.c];
    const int gz = z < opt.depth_bins[0] ? 0 : z < opt.depth_bins[1] ? 1 : z < opt.depth_bins[2] ? 2 : 3;
    return (gz * opt.grid_rows + gy) * opt.grid_cols + gx;
  };

  struct Motion {
    SE3 T;
    std::vector<int> inliers;  // indices into m
    int cells = 0, depth_bins = 0;
    bool whole() const { return depth_bins >= 3; }
  };
  const int cells_per_bin = opt.grid_cols * opt.grid_rows;
  std::vector<Motion> motions;
  std::vector<char> taken(m.size(), 0);
  std::mt19937 rng(12345u + unsigned(m.size()));
  for (int h = 0; h < opt.max_motions; ++h) {
    std::vector<int> free, near_free;
    for (size_t i = 0; i < m.size(); ++i)
      if (!taken[i]) {
        free.push_back(int(i));
        if (m[i].X.z() < near) near_free.push_back(int(i));
      }
    if (int(free.size()) < opt.min_inliers) break;
    const std::vector<int>& pool = near_free.size() >= 10 ? near_free : free;
    Motion best;
    for (int it = 0; it < opt.iterations; ++it) {
      std::uniform_int_distribution<size_t> pick(0, pool.size() - 1);
      const int a = pool[pick(rng)], b = pool[pick(rng)], c = pool[pick(rng)];
      if (a == b || b == c || a == c) continue;
      Eigen::Matrix3d src, dst;
      src << m[a].X, m[b].X, m[c].X;
      // Targets: the current frame's own stereo points.
      dst << unproject(cur, m[a].c, k), unproject(cur, m[b].c, k), unproject(cur, m[c].c, k);
      // A degenerate sample (points nearly on a line) fixes no rotation.
      if ((src.col(1) - src.col(0)).cross(src.col(2) - src.col(0)).norm() < 0.05) continue;
      const Eigen::Matrix4d T4 = Eigen::umeyama(src, dst, false);
      const SE3 T(Eigen::Quaterniond(T4.topLeftCorner<3, 3>()).normalized(), T4.topRightCorner<3, 1>());
      std::vector<int> in;
      for (int i : free)
        if (fits(k, T, m[i])) in.push_back(i);
      if (in.size() > best.inliers.size()) best.T = T, best.inliers = std::move(in);
    }
    if (int(best.inliers.size()) < opt.min_inliers) break;
    // Refine on the inliers by reprojection, then take every free match that fits the refined motion.
    std::vector<PoseObservation> obs;
    for (int i : best.inliers) obs.push_back(m[i].obs);
    std::vector<char> flag;
    SE3 T = best.T;
    optimize_pose(T, k, obs, flag, 2);
    best.T = T;
    best.inliers.clear();
    for (int i : free)
      if (fits(k, T, m[i])) best.inliers.push_back(i);
    if (int(best.inliers.size()) < opt.min_inliers) break;
    std::set<int> cells;
    int per_bin[4] = {0, 0, 0, 0};
    for (int i : best.inliers) {
      const int cell = cell_of(m[i]);
      cells.insert(cell), taken[i] = 1;
      ++per_bin[cell / cells_per_bin];
    }
    best.cells = int(cells.size());
    for (int b : per_bin) best.depth_bins += b >= 5;
    if (best.cells < opt.whole_view_cells) best.depth_bins = std::min(best.depth_bins, 2);
    motions.push_back(std::move(best));
  }
  out.motions = int(motions.size());
  if (motions.empty()) return out;
  auto agrees = [&](const SE3& T) {
    const double tol = opt.predict_translation + opt.predict_translation_share * predicted->t.norm();
    return (T.t - predicted->t).norm() < tol && angle_deg(T, *predicted) < opt.predict_rotation_deg;
  };
  // Camera displacement in the previous camera's frame: x sideways, z forwards.
  auto sideways = [&](const SE3& T) {
    if (predicted || !(opt.sideways_limit > 0)) return false;
    const Eigen::Vector3d d = T.inverse().t;
    return std::abs(d.x()) > std::max(opt.sideways_limit, std::abs(d.z()));
  };
  bool any_forward = false;
  for (const Motion& mo : motions) any_forward |= !sideways(mo.T);
  long chosen = -1;
  // Without a prediction that any motion agrees with, the static world seen whole (over several depths) is taken.
  bool any_agrees = false;
  if (predicted)
    for (const Motion& mo : motions) any_agrees |= agrees(mo.T);
  for (size_t h = 0; h < motions.size(); ++h) {
    if (predicted && any_agrees && !agrees(motions[h].T)) continue;
    if (predicted && !any_agrees && !motions[h].whole()) continue;
    if (any_forward && sideways(motions[h].T)) continue;
    // Depth spread first (a vehicle is one patch at one depth), then coverage, then support.
    if (chosen >= 0 && motions[h].whole() != motions[chosen].whole()) {
      if (motions[h].whole()) chosen = long(h);
      continue;
    }
    if (chosen < 0 || motions[h].cells > motions[chosen].cells ||
        (motions[h].cells == motions[chosen].cells && motions[h].inliers.size() > motions[chosen].inliers.size()))
      chosen = long(h);
  }
  if (chosen < 0) {
    // Nothing agrees with the prediction: no measurement, but coherent groups of matches that land far
    // from where the prediction puts them are moving objects.
    out.disagrees = true;
    const double r2 = double(opt.moving_px) * opt.moving_px;
    for (const Motion& mo : motions)
      for (int i : mo.inliers) {
        const Eigen::Vector3d pc = predicted->q * m[i].X + predicted->t;
        if (pc.z() <= 0) continue;
        const double du = k.fx * pc.x() / pc.z() + k.cx - m[i].obs.u, dv = k.fy * pc.y() / pc.z() + k.cy - m[i].obs.v;
        if (du * du + dv * dv > r2) out.moving[m[i].c] = 1;
      }
    for (char c : out.moving) out.moving_features += c;
    return out;
  }
  const Motion& w = motions[chosen];
  out.ok = true;
  out.T_cp = w.T;
  out.inliers = int(w.inliers.size());
  out.cells = w.cells;
  out.depth_bins = w.depth_bins;
  out.whole_view = w.whole();
  out.disagrees = predicted && !any_agrees;
  for (size_t h = 0; h < motions.size(); ++h) {
    if (long(h) == chosen) continue;
    const SE3 d = motions[h].T * w.T.inverse();
    if (d.t.norm() < opt.distinct_translation && angle_deg(motions[h].T, w.T) < opt.distinct_rotation_deg) continue;
    out.runner_up_cells = std::max(out.runner_up_cells, motions[h].cells);
    out.runner_up_inliers = std::max(out.runner_up_inliers, int(motions[h].inliers.size()));
    if (!predicted) out.chosen_without_prediction = true;
    for (int i : motions[h].inliers)
      if (!fits(k, w.T, m[i])) out.moving[m[i].c] = 1;
  }
  // Features matched no further than the previous frame take the verdict of their matched neighbours (same
  // image patch, similar depth): a vehicle's unmatched features are on the vehicle too.
  if (std::count(out.moving.begin(), out.moving.end(), 1) > 0) {
    std::vector<char> verdict(cur.size(), 0);  // 1 static, 2 moving
    for (const Pair& q : m) verdict[q.c] = out.moving[q.c] ? 2 : fits(k, w.T, q) ? 1 : 0;
    FeatureGrid grid(cur.kps, width, height);
    std::vector<int> near;
    for (size_t i = 0; i < cur.size(); ++i) {
      if (verdict[i] || !cur.has_depth(i)) continue;
      grid.query(cur.kps[i].pt.x, cur.kps[i].pt.y, 20, near);
      int mov = 0, stat = 0;
      for (int j : near)
        if (verdict[j] && std::abs(cur.depth[j] - cur.depth[i]) < 0.15f * cur.depth[i]) (verdict[j] == 2 ? mov : stat)++;
      if (mov > stat) out.moving[i] = 1;
    }
  }
  for (char c : out.moving) out.moving_features += c;
  return out;
}

}  // namespace chungs::tracking
