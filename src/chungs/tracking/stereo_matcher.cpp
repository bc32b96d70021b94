#include "chungs/tracking/stereo_matcher.hpp"

#include <algorithm>
#include <cmath>

namespace chungs::tracking {
namespace {

// Sum of absolute differences of two (2r+1)^2 patches; the caller keeps both inside the images.
int sad(const cv::Mat& a, int ax, int ay, const cv::Mat& b, int bx, int by, int r) {
  int s = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const uint8_t* pa = a.ptr<uint8_t>(ay + dy) + ax;
    const uint8_t* pb = b.ptr<uint8_t>(by + dy) + bx;
    for (int dx = -r; dx <= r; ++dx) s += std::abs(int(pa[dx]) - int(pb[dx]));
  }
  return s;
}

}  // namespace

int match_stereo(const cv::Mat& lg, const cv::Mat& rg, Features& left, const Features& right, double bf,
                 const StereoOptions& opt) {
  if (lg.size() != rg.size()) fail("match_stereo: left ", lg.cols, "x", lg.rows, " and right ", rg.cols, "x", rg.rows, " differ");
  if (!(bf > 0)) fail("match_stereo: fx * baseline must be positive, got ", bf);
  const int rows = lg.rows;
  // Right keypoints listed on every row their (scale-dependent) vertical tolerance covers.
  std::vector<std::vector<int>> by_row(rows);
  for (int j = 0; j < int(right.size()); ++j) {
    const auto& k = right.kps[j];
    float tol = 2.f * level_scale(k.octave);
    int y0 = std::max(0, int(std::floor(k.pt.y - tol))), y1 = std::min(rows - 1, int(std::ceil(k.pt.y + tol)));
    for (int y = y0; y <= y1; ++y) by_row[y].push_back(j);
  }
  const float max_disp = float(bf / opt.min_depth);
  const int r = opt.patch_radius, w = opt.search_radius;
  std::vector<std::pair<int, int>> sads;  // (sad, left index) for outlier rejection
  for (int i = 0; i < int(left.size()); ++i) {
    left.depth[i] = 0;
    left.u_right[i] = kNoRight;
    const auto& kl = left.kps[i];
    int y = std::clamp(int(std::lround(kl.pt.y)), 0, rows - 1);
    int best = opt.max_descriptor_distance + 1, best_j = -1;
    for (int j : by_row[y]) {
      const auto& kr = right.kps[j];
      if (std::abs(kr.octave - kl.octave) > 1) continue;
      float d = kl.pt.x - kr.pt.x;
      if (d < 0 || d > max_disp) continue;
      int h = hamming(left.desc.ptr<uint8_t>(i), right.desc.ptr<uint8_t>(j));
      if (h < best) best = h, best_j = j;
    }
    if (best_j < 0) continue;
    // Sub-pixel: SAD along the row around the match, parabola through the minimum and its neighbours.
    const int ul = int(std::lround(kl.pt.x)), vl = y;
    const int ur0 = int(std::lround(right.kps[best_j].pt.x));
    if (vl - r < 0 || vl + r >= rows || ul - r < 0 || ul + r >= lg.cols) continue;
    if (ur0 - w - r - 1 < 0 || ur0 + w + r + 1 >= rg.cols) continue;
    std::vector<int> cost(2 * w + 3);
    for (int k = -w - 1; k <= w + 1; ++k) cost[k + w + 1] = sad(lg, ul, vl, rg, ur0 + k, vl, r);
    int kbest = 1;
    for (int k = 1; k <= 2 * w + 1; ++k)
      if (cost[k] < cost[kbest]) kbest = k;
    float c0 = float(cost[kbest - 1]), c1 = float(cost[kbest]), c2 = float(cost[kbest + 1]);
    float denom = c0 - 2 * c1 + c2;
    float delta = denom > 0 ? 0.5f * (c0 - c2) / denom : 0.f;
    if (std::abs(delta) > 1.f) continue;
    // The patch sits at the rounded left column: carry the left keypoint's own sub-pixel offset over.
    float u_r = float(ur0 + kbest - w - 1) + delta + (kl.pt.x - float(ul));
    float disp = kl.pt.x - u_r;
    if (disp <= 0.05f || disp > max_disp) continue;
    left.depth[i] = float(bf / disp);
    left.u_right[i] = u_r;
    sads.emplace_back(cost[kbest], i);
  }
  // Matches whose patch cost is far above the typical one are on occlusions or repeated texture.
  if (!sads.empty()) {
    std::vector<int> vals;
    for (auto& s : sads) vals.push_back(s.first);
    std::nth_element(vals.begin(), vals.begin() + vals.size() / 2, vals.end());
    const float thresh = 1.5f * 1.4f * float(vals[vals.size() / 2]);
    for (auto& [c, i] : sads)
      if (float(c) > thresh) left.depth[i] = 0, left.u_right[i] = kNoRight;
  }
  int n = 0;
  for (float d : left.depth) n += d > 0;
  return n;
}

int attach_depth(const ImageF& depth, Features& f, double bf, float min_depth, float max_depth) {
  int n = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    int x = int(std::lround(f.kps[i].pt.x)), y = int(std::lround(f.kps[i].pt.y));
    f.depth[i] = 0;
    f.u_right[i] = kNoRight;
    if (x < 0 || y < 0 || x >= depth.width() || y >= depth.height()) continue;
    float z = depth(x, y);
    if (!(z >= min_depth && z <= max_depth)) continue;
    // Corners on an occluding edge are where the depth jumps: the pixel's depth may belong to either side,
    // and the corner itself slides along the edge as the camera moves, so it gets no depth at all.
    float lo = z, hi = z;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        const int xx = std::clamp(x + dx, 0, depth.width() - 1), yy = std::clamp(y + dy, 0, depth.height() - 1);
        const float d = depth(xx, yy);
        if (!(d > 0)) continue;
        lo = std::min(lo, d);
        hi = std::max(hi, d);
      }
    if (hi - lo > 0.1f * lo) continue;
    f.depth[i] = z;
    f.u_right[i] = float(f.kps[i].pt.x - bf / z);
    ++n;
  }
  return n;
}

}  // namespace chungs::tracking
