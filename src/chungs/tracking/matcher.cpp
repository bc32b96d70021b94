#include "chungs/tracking/matcher.hpp"

#include <climits>
#include <cmath>
#include <unordered_set>

namespace chungs::tracking {

int search_by_projection(const Map& map, const std::vector<long>& candidates, const SE3& T_cw, const Intrinsics& k,
                         int width, int height, const Features& f, const FeatureGrid& grid, std::vector<long>& matches,
                         const ProjectionSearch& opt, std::vector<long>* visible) {
  std::unordered_set<long> taken;
  for (long m : matches)
    if (m >= 0) taken.insert(m);
  std::vector<int> near;
  int added = 0;
  for (long pid : candidates) {
    if (taken.count(pid)) continue;
    const MapPoint* p = map.point(pid);
    if (!p) continue;
    Eigen::Vector3d pc = T_cw * p->pos;
    if (pc.z() < 0.05) continue;
    double u = k.fx * pc.x() / pc.z() + k.cx, v = k.fy * pc.y() / pc.z() + k.cy;
    if (u < 0 || v < 0 || u > width - 1 || v > height - 1) continue;
    if (visible) visible->push_back(pid);
    grid.query(float(u), float(v), opt.radius * 2.0f, near);  // widest level radius; narrowed per keypoint below
    const double ur_pred = u - k.bf / pc.z();
    int best = INT_MAX, second = INT_MAX, best_i = -1, best_oct = -1, second_oct = -1;
    for (int i : near) {
      if (matches[i] >= 0) continue;
      const auto& kp = f.kps[i];
      const float r = opt.radius * level_scale(kp.octave);
      const double du = kp.pt.x - u, dv = kp.pt.y - v;
      if (du * du + dv * dv > double(r) * r) continue;
      // With a right column, the predicted disparity must agree too.
      if (has_right(f.u_right[i]) && std::abs(f.u_right[i] - ur_pred) > r) continue;
      int d = hamming(p->desc.ptr<uint8_t>(0), f.desc.ptr<uint8_t>(i));
      if (d < best) second = best, second_oct = best_oct, best = d, best_i = i, best_oct = kp.octave;
      else if (d < second) second = d, second_oct = kp.octave;
    }
    if (best_i < 0 || best > opt.max_distance) continue;
    if (second_oct == best_oct && float(best) > opt.ratio * float(second)) continue;
    matches[best_i] = pid;
    taken.insert(pid);
    ++added;
  }
  return added;
}

std::vector<std::pair<int, int>> match_descriptors(const cv::Mat& a, const cv::Mat& b, int max_distance, float ratio) {
  auto nearest = [&](const cv::Mat& x, const cv::Mat& y, bool use_ratio) {
    std::vector<int> nn(x.rows, -1);
    for (int i = 0; i < x.rows; ++i) {
      int best = INT_MAX, second = INT_MAX, bj = -1;
      for (int j = 0; j < y.rows; ++j) {
        int d = hamming(x.ptr<uint8_t>(i), y.ptr<uint8_t>(j));
        if (d < best) second = best, best = d, bj = j;
        else if (d < second) second = d;
      }
      if (best > max_distance) continue;
      if (use_ratio && second != INT_MAX && float(best) > ratio * float(second)) continue;
      nn[i] = bj;
    }
    return nn;
  };
  std::vector<int> ab = nearest(a, b, true), ba = nearest(b, a, false);
  std::vector<std::pair<int, int>> out;
  for (int i = 0; i < int(ab.size()); ++i)
    if (ab[i] >= 0 && ba[ab[i]] == i) out.emplace_back(i, ab[i]);
  return out;
}

}  // namespace chungs::tracking
