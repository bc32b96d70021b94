// Tracking against the local map and the PnP-RANSAC fallback (also used to relocalise after loss).
#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <unordered_map>
#include <unordered_set>

#include "chungs/common/log.hpp"
#include "chungs/tracking/visual_tracker.hpp"

namespace chungs::tracking {

std::vector<long> VisualTracker::keyframes_seeing(const std::vector<long>& points) const {
  std::unordered_map<long, int> votes;
  for (long m : points) {
    if (m < 0) continue;
    if (const MapPoint* p = map_.point(m))
      for (auto& [k, i] : p->obs) ++votes[k];
  }
  std::vector<std::pair<long, int>> ranked(votes.begin(), votes.end());
  std::sort(ranked.begin(), ranked.end(), [](auto& a, auto& b) { return a.second != b.second ? a.second > b.second : a.first > b.first; });
  std::vector<long> out;
  for (auto& [k, n] : ranked)
    if (!map_.kf(k).bad && int(out.size()) < opt_.local_keyframes) out.push_back(k);
  return out;
}

std::vector<long> VisualTracker::local_keyframes(const Current& c) const {
  // Keyframes that observe the points the frame already matched, the more shared the closer.
  std::vector<long> out;
  std::unordered_set<long> seen;
  auto add = [&](long k) {
    if (k >= 0 && !map_.kf(k).bad && seen.insert(k).second) out.push_back(k);
  };
  for (long k : keyframes_seeing(c.matches)) add(k);
  // Neighbours of the best ones bring points the frame may now see for the first time.
  const size_t first = out.size();
  for (size_t i = 0; i < std::min<size_t>(first, 3) && int(out.size()) < 2 * opt_.local_keyframes; ++i)
    for (auto& [k, n] : map_.covisible(out[i], 15, 5)) add(k);
  add(ref_kf_);
  return out;
}

int VisualTracker::track_local_map(Current& c) {
  std::vector<long> kfs = local_keyframes(c);
  std::vector<long> candidates;
  std::unordered_set<long> seen;
  for (long k : kfs)
    for (long pid : map_.kf(k).points)
      if (pid >= 0 && seen.insert(pid).second) candidates.push_back(pid);
  FeatureGrid grid(c.f.kps, width_, height_);
  ProjectionSearch s;
  s.radius = 5;
  std::vector<long> visible;
  search_by_projection(map_, candidates, c.T_cw, k_, width_, height_, c.f, grid, c.matches, s, &visible);
  for (long m : c.matches)
    if (m >= 0) visible.push_back(m);  // matched earlier by the motion model: also inside the frame
  std::unordered_set<long> counted;
  for (long pid : visible)
    if (counted.insert(pid).second)
      if (MapPoint* p = map_.point(pid)) ++p->visible;
  int n = optimize(c);
  for (long m : c.matches)
    if (m >= 0)
      if (MapPoint* p = map_.point(m)) ++p->found;
  return n;
}

bool VisualTracker::track_pnp(Current& c, const std::vector<long>& keyframes) {
  const cv::Mat K = (cv::Mat_<double>(3, 3) << k_.fx, 0, k_.cx, 0, k_.fy, k_.cy, 0, 0, 1);
  // One PnP per group: all given keyframes' points pooled while tracking, one keyframe at a time when
  // relocalising (a pool over the whole map would make descriptor matching ambiguous).
  const bool pooled = !lost_;
  const size_t groups = pooled ? 1 : std::min<size_t>(keyframes.size(), 40);
  for (size_t g = 0; g < groups; ++g) {
    std::vector<long> pids;
    std::unordered_set<long> seen;
    auto take = [&](long k) {
      for (long pid : map_.kf(k).points)
        if (pid >= 0 && map_.point(pid) && seen.insert(pid).second) pids.push_back(pid);
    };
    if (pooled)
      for (long k : keyframes) take(k);
    else
      take(keyframes[g]);
    if (pids.size() < size_t(opt_.min_inliers)) continue;
    cv::Mat desc(int(pids.size()), 32, CV_8U);
    for (size_t i = 0; i < pids.size(); ++i) map_.point(pids[i])->desc.copyTo(desc.row(int(i)));
    auto pairs = match_descriptors(c.f.desc, desc, 64, 0.8f);
    if (pairs.size() < size_t(opt_.min_inliers)) continue;
    std::vector<cv::Point3f> obj;
    std::vector<cv::Point2f> img;
    for (auto& [i, j] : pairs) {
      const auto& X = map_.point(pids[j])->pos;
      obj.emplace_back(float(X.x()), float(X.y()), float(X.z()));
      img.push_back(c.f.kps[i].pt);
    }
    cv::Mat rvec, tvec;
    std::vector<int> inl;
    bool ok = cv::solvePnPRansac(obj, img, K, cv::noArray(), rvec, tvec, false, 300, 4.0f, 0.99, inl, cv::SOLVEPNP_EPNP);
    if (!ok || int(inl.size()) < opt_.min_inliers) continue;
    cv::Mat R;
    cv::Rodrigues(rvec, R);
    Eigen::Matrix3d Re;
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) Re(r, q) = R.at<double>(r, q);
    c.T_cw = SE3(nearest_rotation(Re), Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
    std::fill(c.matches.begin(), c.matches.end(), -1);
    for (int i : inl) c.matches[pairs[i].first] = pids[pairs[i].second];
    int n = optimize(c);
    log::debug("tracking: frame ", c.index, " PnP: ", pairs.size(), " matches, ", inl.size(), " RANSAC inliers, ", n,
               " after refinement");
    if (n >= opt_.min_inliers) return true;
  }
  return false;
}

}  // namespace chungs::tracking
