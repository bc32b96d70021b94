#include "chungs/synth/room.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/synth/rng.hpp"

namespace chungs::synth {
namespace {

using V3f = Eigen::Vector3f;

// A wall seen from inside: positions in (u along the wall, d into the room, z up).
struct Wall {
  Eigen::Vector2f origin, along, inward;
  float length;
  V3f world(float u, float d, float z) const {
    Eigen::Vector2f p = origin + u * along + d * inward;
    return {p.x(), p.y(), z};
  }
};

class RoomBuilder {
 public:
  RoomBuilder(const RoomOptions& o, std::vector<Mesh>& out) : o_(o), out_(out), rng_(o.seed) {}

  void build() {
    const float X = float(o_.size_x), Y = float(o_.size_y);
    walls_ = {Wall{{0, 0}, {1, 0}, {0, 1}, X}, Wall{{X, 0}, {0, 1}, {-1, 0}, Y}, Wall{{X, Y}, {-1, 0}, {0, -1}, X},
              Wall{{0, Y}, {0, -1}, {1, 0}, Y}};
    shell();
    for (int w = 0; w < 4; ++w) furnish_wall(w);
    for (int w = 0; w < 4; ++w) paintings(w);
    centre();
  }

 private:
  // Seeds and colour variations are pure functions of (room seed, object, material slot), not
  // draws from rng_: several of them appear in one expression, whose evaluation order C++ leaves
  // unspecified, and the room must not depend on the compiler.
  uint32_t seed(int salt = 0) const {
    return uint32_t(hash_combine(hash_combine(o_.seed, out_.size()), cur_.materials.size() * 7919 + 1 + salt));
  }
  V3f jitter(V3f c, float amount) const {
    uint64_t h = hash_combine(hash_combine(o_.seed, out_.size() + 1000), cur_.materials.size());
    for (int i = 0; i < 3; ++i) {
      h = mix64(h + uint64_t(c[i] * 1e6f) + uint64_t(i));
      const float u = float(h >> 40) * 0x1.0p-24f;
      c[i] = std::clamp(c[i] * (1 + amount * (u - 0.5f)), 0.f, 1.f);
    }
    return c;
  }
  // Starts a new object mesh; the previous one is finished.
  MeshBuilder begin() {
    finish();
    cur_ = Mesh();
    open_ = true;
    return MeshBuilder(cur_);
  }
  void finish() {
    if (!open_) return;
    cur_.compute_bounds();
    out_.push_back(std::move(cur_));
    open_ = false;
  }
  // Axis-aligned box given in a wall's frame.
  void wall_box(MeshBuilder& b, const Wall& w, float u0, float u1, float d0, float d1, float z0, float z1,
                uint16_t m) {
    const V3f p = w.world(u0, d0, z0), q = w.world(u1, d1, z1);
    b.box(p.cwiseMin(q), p.cwiseMax(q), m, z0 > 0);
  }

  void shell() {
    MeshBuilder b = begin();
    const float X = float(o_.size_x), Y = float(o_.size_y), Z = float(o_.height);
    const auto floor = b.add_material(make_material(MaterialKind::Wood, jitter({0.72f, 0.55f, 0.38f}, 0.3f), {0.42f, 0.28f, 0.17f}, 0.16f, seed()));
    const auto ceil = b.add_material(make_material(MaterialKind::Tiles, {0.9f, 0.9f, 0.87f}, {0.55f, 0.55f, 0.55f}, 0.6f, seed()));
    Material wall_mats[4] = {
        make_material(MaterialKind::Brick, jitter({0.62f, 0.32f, 0.24f}, 0.3f), {0.78f, 0.76f, 0.72f}, 0.075f, seed(10)),
        make_material(MaterialKind::Wallpaper, jitter({0.86f, 0.8f, 0.64f}, 0.2f), jitter({0.5f, 0.32f, 0.3f}, 0.4f), 0.22f, seed(11)),
        make_material(MaterialKind::Plaster, jitter({0.74f, 0.8f, 0.86f}, 0.2f), {0.55f, 0.62f, 0.7f}, 1.f, seed(12)),
        make_material(MaterialKind::Plaster, jitter({0.86f, 0.78f, 0.68f}, 0.2f), {0.68f, 0.58f, 0.48f}, 1.f, seed(13))};
    for (int i = 3; i > 0; --i) std::swap(wall_mats[i], wall_mats[rng_.range(0, i)]);
    b.quad({0, 0, 0}, {X, 0, 0}, {X, Y, 0}, {0, Y, 0}, floor);
    b.quad({0, 0, Z}, {0, Y, Z}, {X, Y, Z}, {X, 0, Z}, ceil);
    const auto skirting = b.add_material(make_material(MaterialKind::Paint, {0.92f, 0.91f, 0.88f}, {0.7f, 0.7f, 0.68f}, 1, seed()));
    for (int i = 0; i < 4; ++i) {
      const Wall& w = walls_[i];
      const auto m = b.add_material(wall_mats[i]);
      b.quad(w.world(0, 0, 0), w.world(w.length, 0, 0), w.world(w.length, 0, Z), w.world(0, 0, Z), m);
      wall_box(b, w, 0, w.length, 0, 0.015f, 0, 0.1f, skirting);
    }
  }

  void furnish_wall(int wi) {
    const Wall& w = walls_[wi];
    float u = 0.25f + float(rng_.uniform(0, 0.4));
    if (wi == 3) {  // the door, near a corner
      door(w, u);
      u += 1.3f;
    }
    if (wi == 1) {  // window with a radiator under it
      u += float(rng_.uniform(0.3, 1.2));
      window(w, u);
      u += 1.5f;
    }
    bool sofa_done = false;
    while (true) {
      const double r = rng_.uniform();
      float width;
      int type;
      if (r < 0.3) type = 0, width = float(rng_.uniform(0.8, 1.4));
      else if (r < 0.55) type = 1, width = float(rng_.uniform(0.8, 1.2));
      else if (r < 0.7 && !sofa_done && w.length >= 5) type = 2, width = float(rng_.uniform(1.8, 2.0));
      else if (r < 0.85) type = 3, width = float(rng_.uniform(1.1, 1.4));
      else type = 4, width = 0.5f;
      if (u + width > w.length - 0.25f) break;
      if (type == 0) bookshelf(w, u, u + width);
      if (type == 1) cabinet(w, u, u + width);
      if (type == 2) sofa(w, u, u + width), sofa_done = true;
      if (type == 3) desk(w, u, u + width);
      if (type == 4) plant(w.world(u + 0.25f, 0.3f, 0));
      u += width + float(rng_.uniform(0.05, 0.6));
    }
  }

  void bookshelf(const Wall& w, float u0, float u1) {
    MeshBuilder b = begin();
    const auto wood = b.add_material(make_material(MaterialKind::Wood, jitter({0.6f, 0.45f, 0.3f}, 0.4f), {0.35f, 0.22f, 0.12f}, 0.1f, seed()));
    const auto books = b.add_material(make_material(MaterialKind::Books, {0, 0, 0}, {0.12f, 0.09f, 0.07f}, 0.4f, seed()));
    const float h = 0.4f * float(rng_.range(4, 5)) + 0.02f, d = 0.35f;
    wall_box(b, w, u0, u0 + 0.02f, 0, d, 0, h, wood);
    wall_box(b, w, u1 - 0.02f, u1, 0, d, 0, h, wood);
    for (float z = 0; z < h - 0.01f; z += 0.4f) wall_box(b, w, u0 + 0.02f, u1 - 0.02f, 0, d, z, z + 0.02f, wood);
    wall_box(b, w, u0 + 0.02f, u1 - 0.02f, 0, d, h - 0.02f, h, wood);
    // Book spines (drawn by the Books material in rows of 0.4 m) a little behind the shelf front.
    const V3f p0 = w.world(u0 + 0.02f, 0.26f, 0.02f), p1 = w.world(u1 - 0.02f, 0.26f, 0.02f);
    b.quad(p0, p1, p1 + V3f(0, 0, h - 0.04f), p0 + V3f(0, 0, h - 0.04f), books);
  }

  void cabinet(const Wall& w, float u0, float u1) {
    MeshBuilder b = begin();
    const auto wood = b.add_material(make_material(MaterialKind::Wood, jitter({0.55f, 0.38f, 0.25f}, 0.4f), {0.3f, 0.18f, 0.1f}, 0.12f, seed()));
    const auto front = b.add_material(make_material(MaterialKind::Paint, jitter({0.3f, 0.45f, 0.55f}, 0.6f), {0.2f, 0.2f, 0.2f}, 1, seed()));
    const auto metal = b.add_material(make_material(MaterialKind::Paint, {0.75f, 0.72f, 0.6f}, {0.4f, 0.4f, 0.4f}, 1, seed()));
    const float h = float(rng_.uniform(0.75, 1.0)), d = 0.5f;
    wall_box(b, w, u0, u1, 0, d, 0, h, wood);
    const int drawers = 3;
    const float dh = (h - 0.12f) / drawers;
    for (int k = 0; k < drawers; ++k) {
      const float z0 = 0.08f + k * dh;
      wall_box(b, w, u0 + 0.04f, u1 - 0.04f, d, d + 0.02f, z0 + 0.01f, z0 + dh - 0.01f, front);
      const float um = 0.5f * (u0 + u1);
      wall_box(b, w, um - 0.06f, um + 0.06f, d + 0.02f, d + 0.04f, z0 + 0.5f * dh - 0.015f, z0 + 0.5f * dh + 0.015f, metal);
    }
    const auto vase = b.add_material(make_material(MaterialKind::Poster, {0, 0, 0}, {0, 0, 0}, 0.15f, seed()));
    b.prism(w.world(u0 + 0.25f, 0.25f, h), 0.08f, 0.05f, 0.3f, 8, vase);
    wall_box(b, w, u1 - 0.45f, u1 - 0.15f, 0.1f, 0.35f, h, h + 0.06f, vase);
  }

  void sofa(const Wall& w, float u0, float u1) {
    MeshBuilder b = begin();
    const V3f c1 = jitter({0.35f, 0.4f, 0.55f}, 0.8f), c2 = jitter({0.75f, 0.7f, 0.55f}, 0.5f);
    const auto fabric = b.add_material(make_material(MaterialKind::Fabric, c1, c1 * 0.6f, 0.12f, seed()));
    const auto cushion = b.add_material(make_material(MaterialKind::Fabric, c2, c1, 0.08f, seed()));
    wall_box(b, w, u0, u1, 0, 0.85f, 0, 0.42f, fabric);
    wall_box(b, w, u0, u1, 0, 0.22f, 0.42f, 0.88f, fabric);
    wall_box(b, w, u0, u0 + 0.2f, 0.22f, 0.85f, 0.42f, 0.62f, fabric);
    wall_box(b, w, u1 - 0.2f, u1, 0.22f, 0.85f, 0.42f, 0.62f, fabric);
    const float cw = (u1 - u0 - 0.4f) / 3;
    for (int k = 0; k < 3; ++k)
      wall_box(b, w, u0 + 0.2f + k * cw + 0.01f, u0 + 0.2f + (k + 1) * cw - 0.01f, 0.24f, 0.82f, 0.42f, 0.55f, cushion);
  }

  void desk(const Wall& w, float u0, float u1) {
    MeshBuilder b = begin();
    const auto wood = b.add_material(make_material(MaterialKind::Wood, jitter({0.7f, 0.55f, 0.4f}, 0.3f), {0.45f, 0.3f, 0.2f}, 0.2f, seed()));
    const auto dark = b.add_material(make_material(MaterialKind::Paint, {0.12f, 0.12f, 0.13f}, {0.3f, 0.3f, 0.3f}, 1, seed()));
    const auto screen = b.add_material(make_material(MaterialKind::Poster, {0, 0, 0}, {0, 0, 0}, 0.25f, seed()));
    const auto chair = b.add_material(make_material(MaterialKind::Fabric, jitter({0.6f, 0.2f, 0.15f}, 0.6f), {0.2f, 0.2f, 0.2f}, 0.05f, seed()));
    wall_box(b, w, u0, u1, 0, 0.7f, 0.72f, 0.75f, wood);
    for (float lu : {u0 + 0.03f, u1 - 0.07f})
      for (float ld : {0.03f, 0.63f}) wall_box(b, w, lu, lu + 0.04f, ld, ld + 0.04f, 0, 0.72f, dark);
    const float um = 0.5f * (u0 + u1);
    wall_box(b, w, um - 0.32f, um + 0.32f, 0.12f, 0.16f, 0.85f, 1.25f, dark);
    const V3f s0 = w.world(um - 0.3f, 0.161f, 0.87f), s1 = w.world(um + 0.3f, 0.161f, 0.87f);
    b.quad(s0, s1, s1 + V3f(0, 0, 0.36f), s0 + V3f(0, 0, 0.36f), screen);
    wall_box(b, w, um - 0.03f, um + 0.03f, 0.1f, 0.14f, 0.75f, 0.85f, dark);
    wall_box(b, w, um - 0.25f, um + 0.25f, 0.55f, 0.95f, 0.44f, 0.5f, chair);
    wall_box(b, w, um - 0.25f, um + 0.25f, 0.9f, 0.95f, 0.5f, 0.95f, chair);
    wall_box(b, w, um - 0.03f, um + 0.03f, 0.72f, 0.78f, 0, 0.44f, dark);
  }

  void plant(const V3f& base) {
    MeshBuilder b = begin();
    const auto pot = b.add_material(make_material(MaterialKind::Concrete, jitter({0.7f, 0.45f, 0.35f}, 0.4f), {0, 0, 0}, 0.3f, seed()));
    const auto leaves = b.add_material(make_material(MaterialKind::Foliage, {0.12f, 0.3f, 0.1f}, {0.35f, 0.6f, 0.2f}, 0.12f, seed()));
    b.prism(base, 0.16f, 0.2f, 0.35f, 10, pot);
    b.blob(base + V3f(0, 0, 0.8f), 0.32f, 0.32f, 0.42f, 0.25f, seed(), leaves);
  }

  void door(const Wall& w, float u) {
    MeshBuilder b = begin();
    const auto frame = b.add_material(make_material(MaterialKind::Paint, {0.93f, 0.92f, 0.9f}, {0.8f, 0.8f, 0.8f}, 1, seed()));
    const auto leaf = b.add_material(make_material(MaterialKind::Wood, jitter({0.65f, 0.48f, 0.3f}, 0.3f), {0.38f, 0.25f, 0.15f}, 0.9f, seed()));
    const auto metal = b.add_material(make_material(MaterialKind::Paint, {0.7f, 0.68f, 0.6f}, {0.4f, 0.4f, 0.4f}, 1, seed()));
    wall_box(b, w, u - 0.08f, u + 0.98f, 0, 0.025f, 0, 2.12f, frame);
    wall_box(b, w, u, u + 0.9f, 0, 0.04f, 0, 2.05f, leaf);
    wall_box(b, w, u + 0.75f, u + 0.85f, 0.04f, 0.07f, 1.0f, 1.03f, metal);
  }

  void window(const Wall& w, float u) {
    MeshBuilder b = begin();
    const auto frame = b.add_material(make_material(MaterialKind::Paint, {0.95f, 0.95f, 0.93f}, {0.8f, 0.8f, 0.8f}, 1, seed()));
    // Trees outside the window (unlit: it is daylight beyond the glass).
    Material view = make_material(MaterialKind::Foliage, {0.25f, 0.4f, 0.3f}, {0.75f, 0.85f, 0.6f}, 0.6f, seed());
    view.lit = false;
    const auto glass = b.add_material(view);
    const auto fins = b.add_material(make_material(MaterialKind::Wallpaper, {0.93f, 0.93f, 0.92f}, {0.7f, 0.7f, 0.7f}, 0.06f, seed()));
    wall_box(b, w, u, u + 1.2f, 0, 0.03f, 0.95f, 2.15f, frame);
    wall_box(b, w, u + 0.06f, u + 1.14f, 0, 0.035f, 1.01f, 2.09f, glass);
    wall_box(b, w, u + 0.58f, u + 0.62f, 0, 0.05f, 1.01f, 2.09f, frame);
    wall_box(b, w, u + 0.06f, u + 1.14f, 0, 0.05f, 1.53f, 1.57f, frame);
    wall_box(b, w, u + 0.1f, u + 1.1f, 0.03f, 0.12f, 0.15f, 0.75f, fins);
  }

  void paintings(int wi) {
    const Wall& w = walls_[wi];
    const int n = rng_.range(1, 2);
    for (int k = 0; k < n; ++k) {
      MeshBuilder b = begin();
      const auto frame = b.add_material(make_material(MaterialKind::Wood, {0.3f, 0.2f, 0.12f}, {0.15f, 0.1f, 0.05f}, 0.05f, seed()));
      const auto art = b.add_material(make_material(MaterialKind::Poster, {0, 0, 0}, {0, 0, 0}, float(rng_.uniform(0.3, 0.6)), seed()));
      const float pw = float(rng_.uniform(0.5, 1.1)), ph = float(rng_.uniform(0.4, 0.85));
      const float span = (w.length - 1.0f) / n;
      const float u = 0.5f + span * k + float(rng_.uniform(0, std::max(0.0f, span - pw)));
      const float z = float(rng_.uniform(1.35, 1.6));
      wall_box(b, w, u - 0.04f, u + pw + 0.04f, 0, 0.025f, z - 0.04f, z + ph + 0.04f, frame);
      wall_box(b, w, u, u + pw, 0, 0.03f, z, z + ph, art);
    }
  }

  void centre() {
    const float cx = float(o_.size_x) / 2 + float(rng_.uniform(-0.2, 0.2)), cy = float(o_.size_y) / 2 + float(rng_.uniform(-0.2, 0.2));
    {
      MeshBuilder b = begin();
      const V3f c1 = jitter({0.6f, 0.25f, 0.2f}, 0.8f);
      const auto rug = b.add_material(make_material(MaterialKind::Fabric, c1, jitter({0.85f, 0.8f, 0.6f}, 0.3f), 0.25f, seed()));
      b.box({cx - 1.0f, cy - 0.7f, 0}, {cx + 1.0f, cy + 0.7f, 0.012f}, rug);
    }
    MeshBuilder b = begin();
    const auto wood = b.add_material(make_material(MaterialKind::Wood, jitter({0.5f, 0.35f, 0.22f}, 0.3f), {0.25f, 0.15f, 0.08f}, 0.12f, seed()));
    const auto mags = b.add_material(make_material(MaterialKind::Poster, {0, 0, 0}, {0, 0, 0}, 0.12f, seed()));
    b.box({cx - 0.5f, cy - 0.3f, 0.4f}, {cx + 0.5f, cy + 0.3f, 0.44f}, wood);
    for (float dx : {-0.45f, 0.41f})
      for (float dy : {-0.25f, 0.21f}) b.box({cx + dx, cy + dy, 0.012f}, {cx + dx + 0.04f, cy + dy + 0.04f, 0.4f}, wood);
    b.box({cx - 0.35f, cy - 0.2f, 0.44f}, {cx - 0.05f, cy + 0.02f, 0.47f}, mags);
    b.prism({cx + 0.2f, cy + 0.05f, 0.44f}, 0.045f, 0.045f, 0.1f, 10, mags);
    const auto lamp = b.add_material(make_material(MaterialKind::Paint, {0.9f, 0.85f, 0.7f}, {0.6f, 0.55f, 0.4f}, 1, seed()));
    const float Z = float(o_.height);
    b.prism({cx, cy, Z - 0.55f}, 0.3f, 0.12f, 0.25f, 12, lamp);
    b.box({cx - 0.01f, cy - 0.01f, Z - 0.3f}, {cx + 0.01f, cy + 0.01f, Z}, lamp);
    finish();
  }

  const RoomOptions& o_;
  std::vector<Mesh>& out_;
  Rng rng_;
  std::vector<Wall> walls_;
  Mesh cur_;
  bool open_ = false;
};

}  // namespace

std::vector<Mesh> build_room(const RoomOptions& opt) {
  std::vector<Mesh> out;
  RoomBuilder(opt, out).build();
  return out;
}

SE3 look_pose(const Eigen::Vector3d& position, const Eigen::Vector3d& forward, double roll) {
  const Eigen::Vector3d f = forward.normalized();
  Eigen::Vector3d right = f.cross(Eigen::Vector3d::UnitZ());
  right = right.norm() > 1e-9 ? right.normalized() : Eigen::Vector3d::UnitX();
  Eigen::Vector3d down = f.cross(right);
  const Eigen::Vector3d r = std::cos(roll) * right + std::sin(roll) * down;
  down = f.cross(r);
  Eigen::Matrix3d R;
  R.col(0) = r;
  R.col(1) = down;
  R.col(2) = f;
  return SE3(R, position);
}

Trajectory room_trajectory(const RoomOptions& o, size_t frames) {
  Trajectory traj;
  const double a = std::max(0.3, o.size_x / 2 - 1.5), b = std::max(0.3, o.size_y / 2 - 1.4);
  const Eigen::Vector3d c(o.size_x / 2, o.size_y / 2, 0);
  for (size_t i = 0; i < frames; ++i) {
    const double t = double(i) / o.rate_hz;
    const double th = 2 * M_PI * t / o.loop_seconds;
    const Eigen::Vector3d p = c + Eigen::Vector3d(a * std::cos(th), b * std::sin(th), 1.45 + 0.12 * std::sin(2 * th));
    // Outward (towards the walls) at th = 0, across the centre at th = pi; periodic in th.
    const double yaw = th + M_PI * (0.5 - 0.5 * std::cos(th)) + 0.25 * std::sin(3 * th);
    const double pitch = -0.15 + 0.1 * std::sin(2 * th + 0.5);
    const Eigen::Vector3d f(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
    traj.push_back(o.start_time + t, look_pose(p, f, 0.03 * std::sin(5 * th)));
  }
  return traj;
}

Camera tum_camera(int width, int height) {
  const double sx = width / 640.0, sy = height / 480.0;
  return Camera(width, height, 525.0 * sx, 525.0 * sy, 320.0 * sx - 0.5, 240.0 * sy - 0.5);
}

}  // namespace chungs::synth
