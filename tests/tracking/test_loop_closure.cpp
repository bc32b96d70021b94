// Loop closure on a synthetic feature world: a camera circles inside a textured cylinder with drifting
// odometry; when it comes back, the loop must be detected, verified and closed by the pose graph.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "chungs/geometry/umeyama.hpp"
#include "chungs/tracking/loop_closer.hpp"

using namespace chungs;
using namespace chungs::tracking;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct World {
  std::vector<Eigen::Vector3d> pts;
  std::vector<std::array<uint8_t, 32>> desc;
};

World make_world(std::mt19937& rng, int n) {
  World w;
  std::uniform_real_distribution<double> ang(0, 2 * kPi), h(-2, 2);
  for (int i = 0; i < n; ++i) {
    double a = ang(rng);
    w.pts.emplace_back(10 * std::cos(a), h(rng), 10 * std::sin(a));  // y is down in camera terms: a vertical wall
    std::array<uint8_t, 32> d;
    for (auto& b : d) b = uint8_t(rng());
    w.desc.push_back(d);
  }
  return w;
}

// Camera on a circle of radius 5 in the x-z plane, looking outward, yaw `a`.
SE3 circle_pose(double a) {
  Eigen::Vector3d c(5 * std::cos(a), 0, 5 * std::sin(a));
  Eigen::Vector3d z(std::cos(a), 0, std::sin(a)), y(0, 1, 0);
  Eigen::Vector3d x = y.cross(z);
  Eigen::Matrix3d R;
  R << x, y, z;
  return SE3(R, c);
}

double ate(const std::vector<SE3>& gt, const std::vector<SE3>& est) {
  std::vector<Eigen::Vector3d> a, b;
  for (size_t i = 0; i < gt.size(); ++i) a.push_back(est[i].t), b.push_back(gt[i].t);
  Sim3 S = umeyama_align(a, b, false);
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += (S * a[i] - b[i]).squaredNorm();
  return std::sqrt(s / double(a.size()));
}

}  // namespace

TEST(LoopCloser, DetectsAndClosesDriftedLoopOnSyntheticCircle) {
  std::mt19937 rng(7);
  World w = make_world(rng, 5000);
  const Intrinsics k{400, 400, 320, 240, 40};
  const int W = 640, H = 480, N = 84;  // 5 degrees per keyframe: 72 make the circle, 12 revisit the start
  std::normal_distribution<double> px(0, 0.5);
  Map map;
  LoopOptions lo;
  LoopCloser closer(lo, k, W, H);
  std::vector<SE3> gt, est;
  std::vector<long> current_id(w.pts.size(), -1);  // map point of each world point while it stays tracked
  std::vector<long> seen_at(w.pts.size(), -10);
  std::vector<LoopEvent> events;
  std::vector<SE3> drifted_before_loop;
  for (int f = 0; f < N; ++f) {
    gt.push_back(circle_pose(f * 5.0 * kPi / 180));
    if (f == 0) est.push_back(gt[0]);
    else {
      // Odometry with a systematic yaw bias and noise: about 0.4 degrees and 1 cm per step.
      SE3 step = gt[f - 1].inverse() * gt[f];
      Eigen::Matrix<double, 6, 1> xi;
      xi << 0.01 * px(rng), 0.01 * px(rng), 0.01, 0.001 * px(rng), 0.007, 0.001 * px(rng);
      est.push_back(est.back() * step * SE3::exp(xi));
    }
    Keyframe kf;
    kf.frame_index = size_t(f);
    kf.stamp = f;
    kf.T_wc = est.back();
    const SE3 T_cw = gt.back().inverse();
    std::vector<int> which;
    std::vector<cv::KeyPoint> kps;
    for (size_t j = 0; j < w.pts.size(); ++j) {
      Eigen::Vector3d p = T_cw * w.pts[j];
      if (p.z() < 0.5) continue;
      double u = k.fx * p.x() / p.z() + k.cx + px(rng), v = k.fy * p.y() / p.z() + k.cy + px(rng);
      if (u < 1 || v < 1 || u > W - 2 || v > H - 2) continue;
      kps.emplace_back(float(u), float(v), 31.f, -1.f, 0.f, 0);
      which.push_back(int(j));
    }
    kf.feat.kps = kps;
    kf.feat.desc.create(int(kps.size()), 32, CV_8U);
    for (size_t i = 0; i < which.size(); ++i) {
      auto d = w.desc[which[i]];
      for (int flip = 0; flip < 3; ++flip) d[rng() % 32] ^= uint8_t(1u << (rng() % 8));
      std::memcpy(kf.feat.desc.ptr<uint8_t>(int(i)), d.data(), 32);
      double z = (T_cw * w.pts[which[i]]).z();
      kf.feat.depth.push_back(float(z));
      kf.feat.u_right.push_back(float(kps[i].pt.x - k.bf / z));
    }
    const long id = map.add_keyframe(std::move(kf)).id;
    const Keyframe& K = map.kf(id);
    for (size_t i = 0; i < which.size(); ++i) {
      const int j = which[i];
      if (seen_at[j] == f - 1 && current_id[j] >= 0 && map.point(current_id[j])) {
        map.add_observation(current_id[j], id, int(i));
      } else {
        const auto& kp = K.feat.kps[i];
        const double z = K.feat.depth[i];
        Eigen::Vector3d pc((kp.pt.x - k.cx) / k.fx * z, (kp.pt.y - k.cy) / k.fy * z, z);
        current_id[j] = map.add_point(K.T_wc * pc, id, int(i));
      }
      seen_at[j] = f;
    }
    if (events.empty()) {
      drifted_before_loop.clear();
      for (long i = 0; i < long(map.keyframes()); ++i) drifted_before_loop.push_back(map.pose(i));
    }
    if (auto ev = closer.process(map, id)) events.push_back(*ev);
  }
  ASSERT_TRUE(closer.has_vocabulary());
  ASSERT_GE(events.size(), 1u) << "no loop detected";
  const LoopEvent& ev = events.front();
  EXPECT_GE(ev.query - ev.match, lo.min_keyframe_gap);
  // After closing, the pose between the two ends of the loop agrees with the truth.
  const SE3 rel_est = ev.new_poses[size_t(ev.match)].second.inverse() * ev.new_poses[size_t(ev.query)].second;
  const SE3 rel_gt = gt[ev.match].inverse() * gt[ev.query];
  const SE3 rel_old = ev.old_poses[size_t(ev.match)].second.inverse() * ev.old_poses[size_t(ev.query)].second;
  std::printf("junction error: %.3f m, %.2f deg before closing; %.3f m, %.2f deg after\n", (rel_old.t - rel_gt.t).norm(),
              (rel_old.inverse() * rel_gt).angle() * 180 / kPi, (rel_est.t - rel_gt.t).norm(),
              (rel_est.inverse() * rel_gt).angle() * 180 / kPi);
  // Not exact: the old points the loop is verified against carry the drift of their first keyframes.
  EXPECT_LT((rel_est.t - rel_gt.t).norm(), 0.15);
  EXPECT_LT((rel_est.inverse() * rel_gt).angle(), 0.2 * (rel_old.inverse() * rel_gt).angle());
  EXPECT_EQ(ev.old_poses.size(), ev.new_poses.size());
  EXPECT_EQ(long(ev.new_poses.size()), ev.query + 1);
  EXPECT_NE(std::find(ev.junction.begin(), ev.junction.end(), ev.query), ev.junction.end());
  EXPECT_NE(std::find(ev.junction.begin(), ev.junction.end(), ev.match), ev.junction.end());

  double path = 0;
  for (long i = 1; i <= ev.query; ++i) path += (gt[i].t - gt[i - 1].t).norm();
  std::vector<SE3> gt_part(gt.begin(), gt.begin() + ev.query + 1), after;
  std::vector<SE3> before(drifted_before_loop.begin(), drifted_before_loop.begin() + ev.query + 1);
  for (long i = 0; i <= ev.query; ++i) after.push_back(ev.new_poses[size_t(i)].second);
  const double ate_before = ate(gt_part, before), ate_after = ate(gt_part, after);
  std::printf("loop %ld -> %ld over %.1f m: ATE %.3f m before closing, %.3f m after (%.2f %% of the path)\n", ev.query,
              ev.match, path, ate_before, ate_after, 100 * ate_after / path);
  EXPECT_GT(ate_before, 0.01 * path);  // the drift is large enough for the test to mean something
  EXPECT_LE(ate_after, 0.01 * path);
}
