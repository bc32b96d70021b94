#include "chungs/tracking/loop_closer.hpp"

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <unordered_set>

#include "chungs/common/log.hpp"
#include "chungs/tracking/matcher.hpp"
#include "chungs/tracking/pose_optimizer.hpp"
#include "chungs/tracking/sim3_pose_graph.hpp"

namespace chungs::tracking {

LoopCloser::LoopCloser(LoopOptions opt, const Intrinsics& k, int width, int height)
    : opt_(std::move(opt)), k_(k), width_(width), height_(height) {
  if (!opt_.vocabulary.empty()) vocab_ = Vocabulary::load(opt_.vocabulary);
}

void LoopCloser::add_to_database(const Map& map, long kf) {
  BowVector v = vocab_->transform(map.kf(kf).feat.desc);
  for (auto& [w, x] : v) inverted_[w].push_back(kf);
  bows_[kf] = std::move(v);
}

std::optional<LoopEvent> LoopCloser::process(Map& map, long kf) {
  if (!vocab_) {
    pending_.push_back(kf);
    if (int(pending_.size()) < opt_.train_keyframes) return std::nullopt;
    std::vector<cv::Mat> docs;
    for (long k : pending_) docs.push_back(map.kf(k).feat.desc);
    vocab_ = Vocabulary::train(docs, opt_.branching, opt_.levels);
    log::info("loop closure: trained a vocabulary of ", vocab_->words(), " words from ", pending_.size(), " keyframes");
    for (long k : pending_) add_to_database(map, k);
    pending_.clear();
    return std::nullopt;
  }
  add_to_database(map, kf);
  if (kf - last_loop_kf_ < opt_.min_keyframe_gap) {
    groups_.clear();
    return std::nullopt;
  }
  const BowVector& q = bows_.at(kf);
  // The query must resemble a candidate at least as much as its own covisible neighbours resemble it.
  std::unordered_set<long> exclude = {kf};
  double min_score = 1.0;
  for (auto& [n, shared] : map.covisible(kf, 15)) {
    exclude.insert(n);
    if (bows_.count(n)) min_score = std::min(min_score, Vocabulary::score(q, bows_.at(n)));
  }
  if (exclude.size() == 1) min_score = 0.0;
  std::unordered_set<long> shared_word;
  for (auto& [w, x] : q)
    for (long c : inverted_[w])
      if (c <= kf - opt_.min_keyframe_gap && !exclude.count(c) && !map.kf(c).bad) shared_word.insert(c);
  std::vector<std::pair<double, long>> ranked;
  for (long c : shared_word) {
    double s = Vocabulary::score(q, bows_.at(c));
    if (s >= min_score) ranked.emplace_back(s, c);
  }
  std::sort(ranked.rbegin(), ranked.rend());
  // A place seen again stays a candidate for several keyframes in a row (the candidate or a neighbour of it);
  // a chance resemblance rarely does. Only such recurring candidates get the costly geometric check.
  std::vector<Group> groups;
  std::vector<long> consistent;
  for (int i = 0; i < std::min<int>(opt_.tracked_candidates, int(ranked.size())); ++i) {
    Group g;
    g.members.insert(ranked[i].second);
    for (auto& [n, shared] : map.covisible(ranked[i].second, 15, 10)) g.members.insert(n);
    for (const Group& p : groups_)
      for (long m : g.members)
        if (p.members.count(m)) {
          g.count = std::max(g.count, p.count + 1);
          break;
        }
    if (g.count >= opt_.consistency && int(consistent.size()) < opt_.candidates) consistent.push_back(ranked[i].second);
    groups.push_back(std::move(g));
  }
  groups_ = std::move(groups);
  for (long candidate : consistent) {
    auto v = verify(map, kf, candidate);
    if (!v) continue;
    // Repeated places (the same facade or block seen in two streets) pass the geometric check; a true
    // revisit only moves the query by the drift accumulated since the candidate, a few percent of the way.
    double path = 0;
    for (long a = v->candidate, b = v->candidate + 1; b <= kf; ++b) {
      if (map.kf(b).bad && b != kf) continue;
      path += (map.pose(b).t - map.pose(a).t).norm();
      a = b;
    }
    const double jump = (v->T_wq.t - map.kf(kf).T_wc.t).norm();
    if (jump > opt_.min_drift_gate + opt_.max_drift_ratio * path) {
      log::info("loop closure: keyframe ", kf, " vs keyframe ", v->candidate, " rejected: it would move the query by ",
                jump, " m after ", path, " m of travel");
      continue;
    }
    log::info("loop closure: keyframe ", kf, " (frame ", map.kf(kf).frame_index, ") matches keyframe ", v->candidate,
              " (frame ", map.kf(v->candidate).frame_index, ", score ", Vocabulary::score(q, bows_.at(v->candidate)), ", ",
              v->pairs.size(), " inliers)");
    groups_.clear();
    return close(map, kf, *v);
  }
  return std::nullopt;
}

std::optional<LoopCloser::Verified> LoopCloser::verify(Map& map, long query, long candidate) const {
  // The candidate's neighbourhood, without anything the query already shares points with.
  std::vector<long> pids;
  std::unordered_set<long> seen;
  std::vector<long> group = {candidate};
  for (auto& [n, s] : map.covisible(candidate, 15, 5)) group.push_back(n);
  for (long g : group)
    for (long pid : map.kf(g).points)
      if (pid >= 0 && map.point(pid) && !map.point(pid)->obs.count(query) && seen.insert(pid).second) pids.push_back(pid);
  if (int(pids.size()) < opt_.min_inliers) return std::nullopt;
  const Features& f = map.kf(query).feat;
  cv::Mat desc(int(pids.size()), 32, CV_8U);
  for (size_t i = 0; i < pids.size(); ++i) map.point(pids[i])->desc.copyTo(desc.row(int(i)));
  auto pairs = match_descriptors(f.desc, desc, 64, 0.8f);
  if (int(pairs.size()) < opt_.min_inliers) return std::nullopt;
  std::vector<cv::Point3f> obj;
  std::vector<cv::Point2f> img;
  for (auto& [i, j] : pairs) {
    const auto& X = map.point(pids[j])->pos;
    obj.emplace_back(float(X.x()), float(X.y()), float(X.z()));
    img.push_back(f.kps[i].pt);
  }
  const cv::Mat K = (cv::Mat_<double>(3, 3) << k_.fx, 0, k_.cx, 0, k_.fy, k_.cy, 0, 0, 1);
  cv::Mat rvec, tvec, R;
  std::vector<int> inl;
  if (!cv::solvePnPRansac(obj, img, K, cv::noArray(), rvec, tvec, false, 300, 4.0f, 0.99, inl, cv::SOLVEPNP_EPNP) ||
      int(inl.size()) < opt_.min_inliers / 2)
    return std::nullopt;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Re(r, c) = R.at<double>(r, c);
  SE3 T_cw(nearest_rotation(Re), Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  // More matches by projecting the whole neighbourhood with the RANSAC pose, then a robust refinement.
  std::vector<long> matches(f.size(), -1);
  for (int i : inl) matches[pairs[i].first] = pids[pairs[i].second];
  FeatureGrid grid(f.kps, width_, height_);
  ProjectionSearch s;
  s.radius = 8;
  search_by_projection(map, pids, T_cw, k_, width_, height_, f, grid, matches, s);
  std::vector<PoseObservation> obs;
  std::vector<std::pair<int, long>> used;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (matches[i] < 0) continue;
    const auto& kp = f.kps[i];
    obs.push_back({map.point(matches[i])->pos, kp.pt.x, kp.pt.y, f.u_right[i], 1.0 / level_scale(kp.octave, opt_.scale_factor)});
    used.emplace_back(int(i), matches[i]);
  }
  std::vector<char> inlier;
  int n = optimize_pose(T_cw, k_, obs, inlier);
  if (n < opt_.min_inliers) return std::nullopt;
  Verified v;
  v.candidate = candidate;
  v.T_wq = T_cw.inverse();
  for (size_t j = 0; j < used.size(); ++j)
    if (inlier[j]) v.pairs.push_back(used[j]);
  if (opt_.similarity) {
    // The query's own points seen again as old points: their distances from the query camera, in the old map
    // (through the verified pose) and in the query's map, differ by the scale drift since the candidate.
    const SE3 T_qw_before = map.kf(query).T_wc.inverse();
    std::vector<double> ratios;
    for (auto& [kp, old] : v.pairs) {
      const long own = map.kf(query).points[size_t(kp)];
      if (own < 0 || own == old || !map.point(own)) continue;
      const double d_old = (T_cw * map.point(old)->pos).norm(), d_own = (T_qw_before * map.point(own)->pos).norm();
      if (d_own > 0 && d_old > 0) ratios.push_back(d_old / d_own);
    }
    if (ratios.size() >= 10) {
      std::nth_element(ratios.begin(), ratios.begin() + long(ratios.size() / 2), ratios.end());
      v.scale = ratios[ratios.size() / 2];
    }
  }
  return v;
}

LoopEvent LoopCloser::close(Map& map, long query, const Verified& v) {
  std::unordered_map<long, SE3> before, poses;
  std::vector<long> alive;
  for (long i = 0; i < long(map.keyframes()); ++i)
    if (!map.kf(i).bad) before[i] = map.kf(i).T_wc, alive.push_back(i);
  // Edges measured on the drifted poses: consecutive keyframes, strong covisibility, earlier loops.
  std::vector<PoseGraphEdge> edges;
  auto rel = [&](long i, long j) { return before.at(i).inverse() * before.at(j); };
  for (size_t a = 1; a < alive.size(); ++a) edges.push_back({alive[a - 1], alive[a], rel(alive[a - 1], alive[a])});
  for (long i : alive)
    for (auto& [j, shared] : map.covisible(i, 100))
      if (j > i && !map.kf(j).bad) edges.push_back({i, j, rel(i, j)});
  for (const auto& e : loop_edges_)
    if (before.count(e.i) && before.count(e.j)) edges.push_back(e);
  // Start from the query side already moved by the correction, so the solver begins near the answer.
  poses = before;
  const SE3 C = v.T_wq * before.at(query).inverse();
  std::vector<long> near_query = {query}, near_match = {v.candidate};
  poses[query] = v.T_wq;
  for (auto& [n, s] : map.covisible(query, 15))
    if (poses.count(n) && n > v.candidate + opt_.min_keyframe_gap / 2) poses[n] = C * before.at(n), near_query.push_back(n);
  // The two sides stay disjoint: a keyframe covisible with both belongs to the query side.
  const std::unordered_set<long> query_side(near_query.begin(), near_query.end());
  for (auto& [n, s] : map.covisible(v.candidate, 15))
    if (poses.count(n) && n < query - opt_.min_keyframe_gap / 2 && !query_side.count(n)) near_match.push_back(n);
  // Loop edges join both neighbourhoods, as many as the covisibility edges that hold each side together;
  // a single edge would be outvoted by them and leave part of the error at the junction.
  std::vector<PoseGraphEdge> new_loops;
  for (long m : near_match)
    for (long n : near_query) new_loops.push_back({m, n, before.at(m).inverse() * poses.at(n)});
  edges.insert(edges.end(), new_loops.begin(), new_loops.end());
  std::unordered_map<long, double> scales;  // similarity only: each keyframe's scale correction
  if (opt_.similarity) {
    // The same graph with a scale per keyframe: edges within one side keep scale 1 (measured on one map), the
    // loop edges carry the scale the verification measured.
    std::unordered_map<long, Sim3> sim;
    for (auto& [id, T] : poses) sim[id] = Sim3(T);
    // The query side starts at its corrected pose with the measured scale.
    for (long n : near_query) sim[n] = Sim3(v.scale, poses.at(n).q, poses.at(n).t);
    std::vector<Sim3Edge> sim_edges;
    for (const auto& e : edges) {
      const bool loop_edge = std::find_if(new_loops.begin(), new_loops.end(), [&](const PoseGraphEdge& l) {
                               return l.i == e.i && l.j == e.j;
                             }) != new_loops.end();
      Sim3 S(e.T_ij);
      if (loop_edge) S = sim.at(e.i).inverse() * sim.at(e.j);
      sim_edges.push_back({e.i, e.j, S, e.weight});
    }
    optimize_sim3_pose_graph(sim, sim_edges, {0, v.candidate});
    for (auto& [id, S] : sim) poses[id] = SE3(S.q, S.t), scales[id] = S.s;
  } else {
    optimize_pose_graph(poses, edges, {0, v.candidate});
  }
  loop_edges_.insert(loop_edges_.end(), new_loops.begin(), new_loops.end());

  // Points move with the keyframe that observes them first (scaled about it with a similarity); then the query
  // re-observes the old points.
  for (const auto& [pid, p] : map.all_points()) {
    (void)p;
    MapPoint* mp = map.point(pid);
    long ref = mp->obs.begin()->first;
    if (!poses.count(ref)) continue;
    const Eigen::Vector3d local = before.at(ref).inverse() * mp->pos;
    mp->pos = poses.at(ref) * (scales.count(ref) ? Eigen::Vector3d(scales.at(ref) * local) : local);
  }
  LoopEvent ev;
  ev.query = query;
  ev.match = v.candidate;
  // Culled keyframes follow their parents; the mapper saw them as keyframes, so they are listed too.
  std::vector<std::pair<long, SE3>> culled;
  for (long i = 0; i < long(map.keyframes()); ++i)
    if (map.kf(i).bad) culled.emplace_back(i, map.pose(i));
  for (long i : alive) {
    map.kf(i).T_wc = poses.at(i);
    ev.old_poses.emplace_back(i, before.at(i));
    ev.new_poses.emplace_back(i, poses.at(i));
  }
  for (auto& [i, old] : culled) {
    ev.old_poses.emplace_back(i, old);
    ev.new_poses.emplace_back(i, map.pose(i));
  }
  for (auto& [kp, pid] : v.pairs)
    if (map.point(pid)) map.add_observation(pid, query, kp);
  std::unordered_set<long> junction = {query, v.candidate};
  for (auto& [n, s] : map.covisible(query, 15)) junction.insert(n);
  for (auto& [n, s] : map.covisible(v.candidate, 15)) junction.insert(n);
  ev.junction.assign(junction.begin(), junction.end());
  std::sort(ev.junction.begin(), ev.junction.end());
  last_loop_kf_ = query;
  return ev;
}

}  // namespace chungs::tracking
