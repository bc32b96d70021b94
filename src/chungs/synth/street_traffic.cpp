// Moving vehicles on the synthetic street (issue 23): cars ahead in the camera's lane, oncoming cars
// in the other lane, cars and vans crossing intersections before the camera reaches them, and a lorry
// crossing close ahead at start-up. They are placed from the route and the drive's poses, never
// within a metre of the camera or of each other, and rendered as meshes whose textures move with them.
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "chungs/common/error.hpp"
#include "chungs/synth/rng.hpp"
#include "chungs/synth/street.hpp"

namespace chungs::synth {
namespace {

using V2 = Eigen::Vector2d;
V2 left_of(const V2& d) { return V2(-d.y(), d.x()); }
V2 right_of(const V2& d) { return V2(d.y(), -d.x()); }

// Footprint rectangle (centre, unit heading, half length, half width): separating-axis overlap test.
struct Rect {
  V2 c, h;
  double hl, hw;
};
bool overlap(const Rect& a, const Rect& b) {
  const V2 axes[4] = {a.h, left_of(a.h), b.h, left_of(b.h)};
  for (const V2& ax : axes) {
    const double ra = a.hl * std::abs(a.h.dot(ax)) + a.hw * std::abs(left_of(a.h).dot(ax));
    const double rb = b.hl * std::abs(b.h.dot(ax)) + b.hw * std::abs(left_of(b.h).dot(ax));
    if (std::abs((b.c - a.c).dot(ax)) > ra + rb) return false;
  }
  return true;
}

void size_of(Vehicle& v, Rng& rng) {
  switch (v.kind) {
    case Vehicle::Kind::Car: v.length = rng.uniform(3.9, 4.7), v.width = 1.8, v.height = 1.5; break;
    case Vehicle::Kind::Van: v.length = rng.uniform(5.0, 6.0), v.width = 2.0, v.height = 2.5; break;
    case Vehicle::Kind::Lorry: v.length = rng.uniform(9.0, 11.0), v.width = 2.5, v.height = 3.6; break;
  }
}

}  // namespace

bool StreetTraffic::place(const Vehicle& v, double t, V2& centre, V2& heading) const {
  if (t < v.t0 || t > v.t1) return false;
  const double travelled = v.speed * (t - v.t0);
  if (v.motion == Vehicle::Motion::Line) {
    centre = v.p0 + travelled * v.d;
    heading = v.d;
    return true;
  }
  V2 p, tan;
  path_.at(path_.advance(v.s0, v.dir * travelled, v.lateral), p, tan);
  centre = p + v.lateral * left_of(tan);
  heading = v.dir * tan;
  return true;
}

StreetTraffic::StreetTraffic(const StreetOptions& o, const Trajectory& drive) : opt_(o), path_(o) {
  if (!(o.traffic >= 0 && o.traffic <= 50)) fail("street traffic: ", o.traffic, " vehicles per 100 m is out of range (0 to 50)");
  if (drive.empty()) return;
  const double v_cam = o.step_m * o.rate_hz;  // the camera's speed, m/s
  const double t_end = drive.stamps.back();
  const double s_begin = path_.start(), s_end = s_begin + v_cam * t_end;
  Rng rng(hash_combine(o.seed, 0x74726166666963ULL));

  // The camera's footprint at time t (interpolated between frames), for the clearance checks.
  auto camera_at = [&](double t, V2& c) {
    const double f = std::clamp(t * o.rate_hz, 0.0, double(drive.size() - 1));
    const size_t i = std::min(size_t(f), drive.size() - 1), j = std::min(i + 1, drive.size() - 1);
    const double w = f - double(i);
    c = ((1 - w) * drive.poses[i].t + w * drive.poses[j].t).head<2>();
  };
  // Vehicles by the 10 s windows they exist in: a check looks only at vehicles of its time.
  std::unordered_map<long, std::vector<size_t>> by_time;
  auto window = [](double t) { return long(std::floor(t / 10.0)); };
  auto accept = [&](Vehicle v) {
    if (!(v.t1 > v.t0)) return false;
    std::vector<size_t> near;
    for (long w = window(v.t0); w <= window(v.t1); ++w)
      if (auto it = by_time.find(w); it != by_time.end()) near.insert(near.end(), it->second.begin(), it->second.end());
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    const double dt = 0.5 / o.rate_hz;
    for (double t = std::max(v.t0, 0.0); t <= std::min(v.t1, t_end + 1.0); t += dt) {
      V2 c, h, cam;
      place(v, t, c, h);
      camera_at(t, cam);
      // The camera (and the right one, 0.54 m beside it) stays clear of the body by a metre or more.
      if (overlap({c, h, 0.5 * v.length + 1.0, 0.5 * v.width + 1.0}, {cam, h, 0.8, 0.8})) return false;
      for (size_t ui : near) {
        const Vehicle& u = vehicles[ui];
        V2 cu, hu;
        if (!place(u, t, cu, hu)) continue;
        if (overlap({c, h, 0.5 * v.length + 0.5, 0.5 * v.width + 0.3}, {cu, hu, 0.5 * u.length + 0.5, 0.5 * u.width + 0.3}))
          return false;
      }
    }
    for (long w = window(v.t0); w <= window(v.t1); ++w) by_time[w].push_back(vehicles.size());
    vehicles.push_back(std::move(v));
    return true;
  };

  if (o.startup_cross) {
    // A lorry crossing right to left in front of the camera, its centre on the camera's line at 0.3 s,
    // at 45 km/h: as near as it can be and still clear the camera's path.
    Vehicle v;
    v.kind = Vehicle::Kind::Lorry;
    v.motion = Vehicle::Motion::Line;
    v.role = "startup";
    v.length = 10.0, v.width = 2.5, v.height = 3.6;
    v.speed = 12.5;
    v.seed = rng.next();
    const Eigen::Matrix3d R = drive.poses[0].rotation();
    const V2 c0 = drive.poses[0].t.head<2>(), h0 = R.col(2).head<2>().normalized();
    v.d = left_of(h0);
    v.t0 = 0;
    v.t1 = 4.0;
    bool placed = false;
    for (double D = 9.0; D < 40 && !placed; D += 0.5) {
      v.p0 = c0 + D * h0 - v.d * v.speed * 0.3;
      placed = accept(v);
    }
    if (!placed) fail("street traffic: no clear place for the start-up lorry ahead of the camera");
  }
  if (o.traffic <= 0) return;

  const double expected = o.traffic * (s_end - s_begin) / 100.0;  // vehicles over the drive
  // Intersections the camera passes: closest approaches to a node centre along the path.
  struct Pass {
    double s;
    V2 centre;
  };
  std::vector<Pass> passes;
  {
    auto dist = [&](double s, V2& node) {
      V2 p, t;
      path_.at(s, p, t);
      node = (p / o.pitch).array().round().matrix() * o.pitch;
      return (p - node).norm();
    };
    const double ds = 0.5;
    for (double s = s_begin + 6; s + ds < s_end; s += ds) {
      V2 n0, n1, n2;
      const double d0 = dist(s - ds, n0), d1 = dist(s, n1), d2 = dist(s + ds, n2);
      if (d1 < 8 && d1 <= d0 && d1 < d2) passes.push_back({s, n1});
    }
  }
  // Crossing traffic: 40 % of the vehicles, spread over the intersections.
  const double per_pass = passes.empty() ? 0 : 0.4 * expected / double(passes.size());
  for (const Pass& ps : passes) {
    const int n = int(std::floor(per_pass + rng.uniform()));
    for (int k = 0; k < n; ++k) {
      Vehicle v;
      v.kind = rng.chance(0.25) ? Vehicle::Kind::Van : Vehicle::Kind::Car;
      size_of(v, rng);
      v.motion = Vehicle::Motion::Line;
      v.role = "crossing";
      v.speed = rng.uniform(10, 60) / 3.6;
      v.seed = rng.next();
      V2 p, din, dout;
      path_.at(ps.s - 12, p, din);
      path_.at(ps.s + 12, p, dout);
      const V2 perp = left_of(din);
      const bool turns = std::abs(dout.dot(din)) < 0.7;
      // Across the camera's way; when the camera turns, on the far lane of the road it turns into.
      v.d = turns ? V2(-(dout.dot(perp) > 0 ? 1.0 : -1.0) * perp) : V2((rng.chance(0.5) ? 1.0 : -1.0) * perp);
      const V2 lane0 = ps.centre + o.lane_offset * right_of(v.d);
      // Where it crosses the camera's lane, and when: the camera is still `gap` metres short of it.
      const double tau_c = (o.lane_offset * right_of(din)).dot(v.d);
      const double gap = v_cam * (0.5 * v.length + 3.0) / v.speed + rng.uniform(3, 20);
      const double t_c = (ps.s - gap - s_begin) / v_cam;
      const double reach = 70;  // metres before and after the crossing it exists
      v.t0 = t_c - reach / v.speed;
      v.t1 = t_c + reach / v.speed;
      v.p0 = lane0 + (tau_c - reach) * v.d;
      if (v.t1 < 0) continue;
      accept(v);
    }
  }
  // Ahead (30 %): turning into the camera's lane at an intersection 25-45 m ahead, then driving on at
  // 40-60 km/h. Oncoming (30 %): in the other lane, passing the camera at a random time.
  const int n_ahead = int(std::floor(0.3 * expected + rng.uniform()));
  for (int k = 0; k < n_ahead && !passes.empty(); ++k) {
    const Pass& ps = passes[size_t(rng.range(0, int(passes.size()) - 1))];
    Vehicle v;
    v.kind = rng.chance(0.2) ? Vehicle::Kind::Van : Vehicle::Kind::Car;
    size_of(v, rng);
    v.role = "ahead";
    v.dir = 1;
    v.speed = rng.uniform(40, 60) / 3.6;
    v.seed = rng.next();
    v.s0 = ps.s;
    v.t0 = std::max(0.0, (ps.s - rng.uniform(25, 45) - s_begin) / v_cam);
    v.t1 = v.t0 + 150 / (v.speed - v_cam);
    accept(v);
  }
  const int n_oncoming = int(std::floor(0.3 * expected + rng.uniform()));
  for (int k = 0; k < n_oncoming; ++k) {
    Vehicle v;
    v.kind = rng.chance(0.2) ? Vehicle::Kind::Van : Vehicle::Kind::Car;
    size_of(v, rng);
    v.role = "oncoming";
    v.dir = -1;
    v.lateral = 2 * o.lane_offset;
    v.speed = rng.uniform(30, 50) / 3.6;
    v.seed = rng.next();
    const double t_meet = rng.uniform(0, t_end);
    const double s_meet = s_begin + v_cam * t_meet;
    const double before = 120 / (v.speed + v_cam);
    v.t0 = t_meet - before;
    v.s0 = path_.advance(s_meet, v.speed * before, v.lateral);
    v.t1 = t_meet + 20 / v.speed;
    accept(v);
  }
}

std::shared_ptr<Mesh> StreetTraffic::mesh(const Vehicle& v, double t) const {
  V2 c, h;
  if (!place(v, t, c, h)) return nullptr;
  using V3f = Eigen::Vector3f;
  static const V3f paints[] = {{0.7f, 0.05f, 0.05f}, {0.1f, 0.2f, 0.5f}, {0.85f, 0.85f, 0.85f}, {0.22f, 0.22f, 0.25f},
                               {0.5f, 0.52f, 0.55f}, {0.2f, 0.4f, 0.25f}, {0.8f, 0.6f, 0.1f}};
  Rng rng(v.seed);
  const V3f paint = paints[rng.range(0, 6)];
  auto m = std::make_shared<Mesh>();
  MeshBuilder b(*m);
  const auto body = b.add_material(make_material(MaterialKind::Paint, paint, paint * 0.6f, 1, uint32_t(rng.next())));
  const auto glass = b.add_material(make_material(MaterialKind::Glass, {0.08f, 0.1f, 0.13f}, {0.6f, 0.65f, 0.72f}, 1, uint32_t(rng.next())));
  const auto tyre = b.add_material(make_material(MaterialKind::Paint, {0.07f, 0.07f, 0.07f}, {0.15f, 0.15f, 0.15f}, 1, uint32_t(rng.next())));
  const auto art = b.add_material(make_material(MaterialKind::Poster, {0, 0, 0}, {0, 0, 0}, 0.5f, uint32_t(rng.next())));
  // Object frame: x forward, y left, z up, origin on the ground under the centre.
  const float L = float(v.length), W = float(v.width), H = float(v.height);
  switch (v.kind) {
    case Vehicle::Kind::Car:
      b.oriented_box({0, 0, 0.3f}, L, W, 0.75f, 0, body);
      b.oriented_box({-0.15f * L, 0, 1.05f}, 0.55f * L, W - 0.2f, H - 1.05f, 0, glass);
      break;
    case Vehicle::Kind::Van:
      b.oriented_box({-0.1f * L, 0, 0.35f}, 0.8f * L, W, H - 0.35f, 0, art);  // a delivery van's livery
      b.oriented_box({0.4f * L, 0, 0.35f}, 0.2f * L, W, 0.8f, 0, body);
      b.oriented_box({0.35f * L, 0, 1.15f}, 0.1f * L, W - 0.1f, H - 1.3f, 0, glass);
      break;
    case Vehicle::Kind::Lorry: {
      const float cab = 2.2f;
      b.oriented_box({0.5f * L - 0.5f * cab, 0, 0.4f}, cab, W, 1.2f, 0, body);
      b.oriented_box({0.5f * L - 0.5f * cab, 0, 1.6f}, cab, W, H - 1.0f - 1.6f, 0, glass);
      b.oriented_box({-0.5f * cab - 0.2f, 0, 0.5f}, L - cab - 0.4f, W, H - 0.5f, 0, art);
      break;
    }
  }
  const float tx = 0.5f * L - 0.8f, ty = 0.5f * W - 0.11f;
  for (float sx : {-tx, tx})
    for (float sy : {-ty, ty}) b.oriented_box({sx, sy, 0}, 0.7f, 0.22f, 0.7f, 0, tyre);
  const double yaw = std::atan2(h.y(), h.x());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3f Rf = R.cast<float>();
  for (auto& p : m->vertices) p = Rf * p;
  m->origin = Eigen::Vector3d(c.x(), c.y(), 0);
  m->object_texture = true;
  m->object_rotation = R;
  m->compute_bounds();
  return m;
}

}  // namespace chungs::synth
