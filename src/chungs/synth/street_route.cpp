// The street route: a walk over the intersections of the grid (loops around blocks, straight runs,
// and returns to earlier streets that then re-drive them in the same direction), turned into a
// smooth right-lane path with rounded corners and sampled every step_m.
#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/synth/rng.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/street.hpp"

namespace chungs::synth {
namespace {

using V2 = Eigen::Vector2d;
using V2i = Eigen::Vector2i;
const V2i kDirs[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};  // east, north, west, south

int heading_of(const V2i& d) {
  for (int h = 0; h < 4; ++h)
    if (kDirs[h] == d) return h;
  fail("street route: nodes ", d.x(), ",", d.y(), " apart are not neighbours");
}

class Planner {
 public:
  Planner(const StreetOptions& o) : rng_(hash_combine(o.seed, 0x726f757465ULL)) {
    nodes_.push_back({0, 0});
    // Rounded corners make the path shorter than its edges; 15 % spare covers a turn at every node.
    // A longer plan has the same beginning (done() only truncates), so the spare changes nothing
    // before length_m.
    edges_needed_ = size_t(std::ceil(1.15 * o.length_m / o.pitch)) + 3;
  }

  std::vector<V2i> plan() {
    loop(1, 1, true);  // the first block at once: even short routes contain a loop
    while (!done()) {
      const double r = rng_.uniform();
      if (r < 0.3) {
        const int a = rng_.range(1, 2), b = rng_.range(1, 2);
        loop(a, b, rng_.chance(0.6));
      } else if (r < 0.75 || nodes_.size() < 12) {
        forward(rng_.range(1, 3));
        const int turn = rng_.range(0, 2);  // straight on, left or right, one block
        move(turn == 0 ? heading_ : turn == 1 ? (heading_ + 1) % 4 : (heading_ + 3) % 4);
      } else {
        revisit();
      }
    }
    return nodes_;
  }

 private:
  bool done() const { return nodes_.size() - 1 >= edges_needed_; }
  void move(int h) {
    if (done()) return;
    heading_ = h;
    nodes_.push_back(nodes_.back() + kDirs[h]);
  }
  void forward(int k) {
    for (int i = 0; i < k; ++i) move(heading_);
  }
  void loop(int a, int b, bool right) {
    const int turn = right ? 3 : 1;
    for (int leg = 0; leg < 4; ++leg) {
      forward(leg % 2 == 0 ? a : b);
      if (leg < 3) heading_ = (heading_ + turn) % 4;
    }
  }
  // Drive back to an intersection of the earlier route, then follow the old route from there for
  // a few blocks, in the same direction as before.
  void revisit() {
    const size_t limit = nodes_.size() > 10 ? nodes_.size() - 10 : 0;
    if (limit == 0) return;
    size_t idx = size_t(rng_.range(0, int(limit) - 1));
    const V2i target = nodes_[idx];
    for (int steps = 0; nodes_.back() != target && steps < 200 && !done(); ++steps) {
      const V2i delta = target - nodes_.back();
      int best = -1, best_gain = 0;
      for (int h : {heading_, (heading_ + 1) % 4, (heading_ + 3) % 4}) {  // never a U-turn
        const int gain = kDirs[h].dot(delta);
        // Prefer the axis with more to go; ties keep the current heading.
        const int axis_left = kDirs[h].x() != 0 ? std::abs(delta.x()) : std::abs(delta.y());
        const int score = gain > 0 ? 10 * axis_left + (h == heading_ ? 1 : 0) : 0;
        if (score > best_gain) best_gain = score, best = h;
      }
      move(best >= 0 ? best : (heading_ + 3) % 4);
    }
    if (nodes_.back() != target) return;
    for (size_t k = idx; k + 1 < nodes_.size() && k < idx + 4 && !done(); ++k) {
      const int h = heading_of(nodes_[k + 1] - nodes_[k]);
      if (h == (heading_ + 2) % 4) break;
      move(h);
    }
  }

  Rng rng_;
  std::vector<V2i> nodes_;
  int heading_ = 0;
  size_t edges_needed_ = 0;
};

std::vector<PathPiece> build_path(const StreetOptions& o, const std::vector<V2i>& nodes) {
  auto right_of = [](const V2& d) { return V2(d.y(), -d.x()); };
  std::vector<PathPiece> pieces;
  const double L = o.lane_offset, R = o.turn_radius;
  auto dir = [&](size_t k) { return (nodes[k + 1] - nodes[k]).cast<double>(); };
  V2 cur = nodes[0].cast<double>() * o.pitch + L * right_of(dir(0));
  auto line_to = [&](const V2& p) {
    PathPiece q;
    q.a = cur;
    q.b = p;
    q.length = (p - cur).norm();
    if (q.length > 1e-9) pieces.push_back(q);
    cur = p;
  };
  for (size_t k = 1; k + 1 < nodes.size(); ++k) {
    const V2 din = dir(k - 1), dout = dir(k);
    if (din == dout) continue;
    if (din == -dout) fail("street route: U-turn at node ", k);
    const V2 corner = nodes[k].cast<double>() * o.pitch + L * (right_of(din) + right_of(dout));
    line_to(corner - R * din);
    PathPiece arc;
    arc.arc = true;
    arc.c = corner - R * din + R * dout;
    arc.din = din;
    arc.dout = dout;
    arc.r = R;
    arc.length = 0.5 * M_PI * R;
    pieces.push_back(arc);
    cur = corner + R * dout;
  }
  line_to(nodes.back().cast<double>() * o.pitch + L * right_of(dir(nodes.size() - 2)));
  return pieces;
}

}  // namespace

void PathPiece::at(double s, V2& p, V2& tangent) const {
  if (!arc) {
    tangent = (b - a).normalized();
    p = a + s * tangent;
    return;
  }
  const double phi = s / r;
  p = c + r * (-dout * std::cos(phi) + din * std::sin(phi));
  tangent = (dout * std::sin(phi) + din * std::cos(phi)).normalized();
}

StreetPath::StreetPath(const StreetOptions& o) {
  nodes_ = street_route_nodes(o);
  pieces_ = build_path(o, nodes_);
  for (const auto& p : pieces_) starts_.push_back(total_), total_ += p.length;
  if (o.start_turn) {
    // Four metres before the first corner: the camera turns within its first frames.
    for (size_t k = 0; k < pieces_.size(); ++k)
      if (pieces_[k].arc) {
        start_ = std::max(0.0, starts_[k] - 4.0);
        break;
      }
  }
}

void StreetPath::at(double s, V2& p, V2& tangent) const {
  s = std::clamp(s, 0.0, total_);
  size_t k = size_t(std::upper_bound(starts_.begin(), starts_.end(), s) - starts_.begin());
  k = k == 0 ? 0 : k - 1;
  pieces_[k].at(std::min(s - starts_[k], pieces_[k].length), p, tangent);
}

double StreetPath::advance(double s, double distance, double lateral) const {
  s = std::clamp(s, 0.0, total_);
  size_t k = size_t(std::upper_bound(starts_.begin(), starts_.end(), s) - starts_.begin());
  k = k == 0 ? 0 : k - 1;
  // Metres of the shifted path per metre of the route in piece k.
  auto scale = [&](size_t i) {
    const PathPiece& p = pieces_[i];
    if (!p.arc) return 1.0;
    const bool left_turn = p.din.x() * p.dout.y() - p.din.y() * p.dout.x() > 0;
    return std::max(0.05, (p.r + (left_turn ? -lateral : lateral)) / p.r);
  };
  double left = distance;
  while (true) {
    const double k_s = scale(k);
    if (left >= 0) {
      const double room = (starts_[k] + pieces_[k].length - s) * k_s;
      if (left <= room || k + 1 == pieces_.size()) return std::min(total_, s + left / k_s);
      left -= room;
      s = starts_[++k];
    } else {
      const double room = (s - starts_[k]) * k_s;
      if (-left <= room || k == 0) return std::max(0.0, s + left / k_s);
      left += room;
      s = starts_[k--];
    }
  }
}

std::vector<Eigen::Vector2i> street_route_nodes(const StreetOptions& opt) {
  if (!(opt.length_m > 0)) fail("street route: length must be positive, got ", opt.length_m, " m");
  if (!(opt.turn_radius > 0 && opt.turn_radius < 0.4 * opt.pitch))
    fail("street route: turn radius ", opt.turn_radius, " m does not fit the ", opt.pitch, " m grid");
  return Planner(opt).plan();
}

Trajectory street_trajectory(const StreetOptions& o, size_t max_frames) {
  if (!(o.step_m > 0) || !(o.rate_hz > 0)) fail("street route: step and rate must be positive");
  if (!(o.length_m > 0 && o.length_m <= kMaxStreetLengthM))
    fail("street route: length must be in (0, ", kMaxStreetLengthM, "] m, got ", o.length_m);
  const StreetPath path(o);
  const auto& pieces = path.pieces();
  const double total = path.length(), start0 = path.start();
  const double want = std::min(o.length_m, total - start0);
  size_t frames = size_t(std::floor(want / o.step_m)) + 1;
  if (max_frames) frames = std::min(frames, max_frames);

  Rng rng(hash_combine(o.seed, 0x73776179ULL));
  const double ph1 = rng.uniform(0, 6.3), ph2 = rng.uniform(0, 6.3), ph3 = rng.uniform(0, 6.3);
  // Small smooth lateral sway, bounce, pitch and roll: the motion is not perfectly planar.
  auto sway = [&](double s) { return 0.1 * std::sin(2 * M_PI * s / 41 + ph1) + 0.05 * std::sin(2 * M_PI * s / 17 + ph2); };
  Trajectory traj;
  size_t pi = 0;
  double start = 0;  // arc length where piece pi starts
  for (size_t i = 0; i < frames; ++i) {
    const double s = start0 + i * o.step_m;
    while (pi + 1 < pieces.size() && s > start + pieces[pi].length) start += pieces[pi++].length;
    V2 p, t;
    pieces[pi].at(std::min(s - start, pieces[pi].length), p, t);
    const V2 right(t.y(), -t.x());
    const double h = 1e-3, dsway = (sway(s + h) - sway(s - h)) / (2 * h);
    p += sway(s) * right;
    const V2 f2 = (t + dsway * right).normalized();
    const double pitch = 0.012 * std::sin(2 * M_PI * s / 13 + ph3);
    const Eigen::Vector3d pos(p.x(), p.y(), o.camera_height + 0.015 * std::sin(2 * M_PI * s / 5.3));
    const Eigen::Vector3d fwd(std::cos(pitch) * f2.x(), std::cos(pitch) * f2.y(), std::sin(pitch));
    traj.push_back(double(i) / o.rate_hz, look_pose(pos, fwd, 0.01 * std::sin(2 * M_PI * s / 9)));
  }
  return traj;
}

}  // namespace chungs::synth
