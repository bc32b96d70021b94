#include "chungs/tracking/map.hpp"

#include <algorithm>

namespace chungs::tracking {

Keyframe& Map::add_keyframe(Keyframe kf) {
  kf.id = long(kfs_.size());
  if (kf.points.size() != kf.feat.size()) kf.points.assign(kf.feat.size(), -1);
  kfs_.push_back(std::move(kf));
  return kfs_.back();
}

long Map::add_point(const Eigen::Vector3d& pos, long kf_id, int kp) {
  MapPoint p;
  p.id = next_point_++;
  p.pos = pos;
  p.first_kf = kf_id;
  p.visible = p.found = 1;
  points_.emplace(p.id, std::move(p));
  add_observation(next_point_ - 1, kf_id, kp);
  return next_point_ - 1;
}

void Map::add_observation(long pid, long kf_id, int kp) {
  MapPoint* p = point(pid);
  if (!p) fail("map: no point ", pid);
  Keyframe& k = kf(kf_id);
  if (kp < 0 || kp >= int(k.points.size())) fail("map: keyframe ", kf_id, " has no keypoint ", kp);
  if (k.points[kp] >= 0 && k.points[kp] != pid) erase_observation(k.points[kp], kf_id);
  auto old = p->obs.find(kf_id);
  if (old != p->obs.end() && old->second != kp) k.points[old->second] = -1;
  p->obs[kf_id] = kp;
  k.points[kp] = pid;
  p->desc = k.feat.desc.row(kp);
}

void Map::erase_observation(long pid, long kf_id) {
  MapPoint* p = point(pid);
  if (!p) return;
  auto it = p->obs.find(kf_id);
  if (it == p->obs.end()) return;
  kf(kf_id).points[it->second] = -1;
  p->obs.erase(it);
  if (p->obs.empty()) points_.erase(pid);
}

void Map::erase_point(long pid) {
  MapPoint* p = point(pid);
  if (!p) return;
  for (auto& [k, i] : p->obs) kf(k).points[i] = -1;
  points_.erase(pid);
}

MapPoint* Map::point(long id) {
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

const MapPoint* Map::point(long id) const {
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

SE3 Map::pose(long id) const {
  const Keyframe& k = kf(id);
  if (!k.bad) return k.T_wc;
  return pose(k.parent) * k.T_parent_this;
}

std::vector<std::pair<long, int>> Map::covisible(long kf_id, int min_shared, size_t max) const {
  std::unordered_map<long, int> count;
  for (long pid : kf(kf_id).points) {
    if (pid < 0) continue;
    const MapPoint* p = point(pid);
    if (!p) continue;
    for (auto& [k, i] : p->obs)
      if (k != kf_id) ++count[k];
  }
  std::vector<std::pair<long, int>> out;
  for (auto& [k, c] : count)
    if (c >= min_shared) out.emplace_back(k, c);
  std::sort(out.begin(), out.end(), [](auto& a, auto& b) { return a.second != b.second ? a.second > b.second : a.first > b.first; });
  if (out.size() > max) out.resize(max);
  return out;
}

void Map::cull_keyframe(long id, long parent) {
  Keyframe& k = kf(id);
  if (k.bad || parent == id || kf(parent).bad) return;
  for (size_t i = 0; i < k.points.size(); ++i)
    if (k.points[i] >= 0) erase_observation(k.points[i], id);
  k.T_parent_this = kf(parent).T_wc.inverse() * k.T_wc;
  k.parent = parent;
  k.bad = true;
}

}  // namespace chungs::tracking
