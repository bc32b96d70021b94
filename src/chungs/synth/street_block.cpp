// One block of the street world: its west and south roads with the intersection at its south-west
// corner, raised sidewalks with kerbs, buildings along the block edges (or a park), street trees,
// lamps, bins and parked cars. Everything is drawn from an Rng seeded by (world seed, block).
#include <algorithm>
#include <cmath>

#include "chungs/synth/rng.hpp"
#include "chungs/synth/street.hpp"

namespace chungs::synth {
namespace {

using V3f = Eigen::Vector3f;

class BlockBuilder {
 public:
  BlockBuilder(const StreetOptions& o, int bx, int by)
      : o_(o), rng_(hash_combine(hash_combine(o.seed, uint64_t(int64_t(bx))), uint64_t(int64_t(by)))), b_(m_) {
    m_.origin = Eigen::Vector3d(bx * o.pitch, by * o.pitch, 0);
    P_ = float(o.pitch);
    hw_ = float(0.5 * o.road_width);
    S_ = float(o.sidewalk);
    park_ = rng_.chance(0.12);
  }

  Mesh build() {
    // Surfaces that continue across blocks share world-level seeds, so their texture is seamless.
    const uint32_t ws = uint32_t(o_.seed * 7919u);
    asphalt_ = b_.add_material(make_material(MaterialKind::Asphalt, {0.27f, 0.27f, 0.29f}, {0, 0, 0}, 2 * hw_, ws + 1, P_));
    kerb_ = b_.add_material(make_material(MaterialKind::Concrete, {0.6f, 0.6f, 0.58f}, {0, 0, 0}, 1.0f, ws + 2));
    paving_ = b_.add_material(make_material(MaterialKind::Paving, {0.62f, 0.6f, 0.56f}, {0.38f, 0.37f, 0.35f}, 0.5f, ws + 3));
    grass_ = b_.add_material(make_material(MaterialKind::Grass, {0.18f, 0.32f, 0.1f}, {0.42f, 0.55f, 0.2f}, 1, ws + 4));
    bark_ = b_.add_material(make_material(MaterialKind::Bark, {0.3f, 0.22f, 0.15f}, {0.12f, 0.09f, 0.06f}, 1, ws + 5));
    leaves_[0] = b_.add_material(make_material(MaterialKind::Foliage, {0.1f, 0.22f, 0.06f}, {0.35f, 0.55f, 0.15f}, 0.9f, ws + 6));
    leaves_[1] = b_.add_material(make_material(MaterialKind::Foliage, {0.16f, 0.2f, 0.05f}, {0.55f, 0.6f, 0.2f}, 0.7f, ws + 7));
    metal_ = b_.add_material(make_material(MaterialKind::Paint, {0.25f, 0.27f, 0.28f}, {0.4f, 0.4f, 0.4f}, 1, ws + 8));
    glass_ = b_.add_material(make_material(MaterialKind::Glass, {0.08f, 0.1f, 0.13f}, {0.6f, 0.65f, 0.72f}, 1, ws + 9));
    tyre_ = b_.add_material(make_material(MaterialKind::Paint, {0.07f, 0.07f, 0.07f}, {0.15f, 0.15f, 0.15f}, 1, ws + 10));
    ground();
    if (park_) park();
    else for (int side = 0; side < 4; ++side) buildings(side);
    for (int side = 0; side < 4; ++side) sidewalk_props(side);
    parked_cars();
    m_.compute_bounds();
    return std::move(m_);
  }

 private:
  uint32_t seed() { return uint32_t(rng_.next()); }

  void ground() {
    const float h = hw_, P = P_, k = 0.15f;
    b_.quad({h, -h, 0}, {P - h, -h, 0}, {P - h, h, 0}, {h, h, 0}, asphalt_);   // south road
    b_.quad({-h, h, 0}, {h, h, 0}, {h, P - h, 0}, {-h, P - h, 0}, asphalt_);   // west road
    b_.quad({-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, h, 0}, asphalt_);         // intersection
    const float a = h, z = P - h, i0 = h + S_, i1 = P - h - S_;
    b_.quad({a, a, k}, {z, a, k}, {z, i0, k}, {a, i0, k}, paving_);
    b_.quad({a, i1, k}, {z, i1, k}, {z, z, k}, {a, z, k}, paving_);
    b_.quad({a, i0, k}, {i0, i0, k}, {i0, i1, k}, {a, i1, k}, paving_);
    b_.quad({i1, i0, k}, {z, i0, k}, {z, i1, k}, {i1, i1, k}, paving_);
    b_.quad({i0, i0, k}, {i1, i0, k}, {i1, i1, k}, {i0, i1, k}, park_ ? grass_ : paving_);
    b_.quad({a, a, 0}, {z, a, 0}, {z, a, k}, {a, a, k}, kerb_);
    b_.quad({z, a, 0}, {z, z, 0}, {z, z, k}, {z, a, k}, kerb_);
    b_.quad({z, z, 0}, {a, z, 0}, {a, z, k}, {z, z, k}, kerb_);
    b_.quad({a, z, 0}, {a, a, 0}, {a, a, k}, {a, z, k}, kerb_);
  }

  // Block edge `side` (0 south, 1 east, 2 north, 3 west) as a frame: u along the edge, d into the
  // block from the building line, world = base + u * along + d * inward.
  struct Frame {
    Eigen::Vector2f base, along, inward;
    V3f at(float u, float d, float z) const {
      Eigen::Vector2f p = base + u * along + d * inward;
      return {p.x(), p.y(), z};
    }
  };
  Frame frame(int side, float line) const {
    const float lo = hw_ + line, hi = P_ - hw_ - line;
    switch (side) {
      case 0: return {{0, lo}, {1, 0}, {0, 1}};
      case 1: return {{hi, 0}, {0, 1}, {-1, 0}};
      case 2: return {{0, hi}, {1, 0}, {0, -1}};
      default: return {{lo, 0}, {0, 1}, {1, 0}};
    }
  }
  void frame_box(const Frame& f, float u0, float u1, float d0, float d1, float z0, float z1, uint16_t m) {
    const V3f p = f.at(u0, d0, z0), q = f.at(u1, d1, z1);
    b_.box(p.cwiseMin(q), p.cwiseMax(q), m, z0 > 0.2f);
  }

  void buildings(int side) {
    static const V3f walls[] = {{0.78f, 0.7f, 0.58f}, {0.62f, 0.3f, 0.22f}, {0.7f, 0.7f, 0.68f}, {0.9f, 0.88f, 0.82f},
                                {0.8f, 0.62f, 0.35f}, {0.6f, 0.68f, 0.75f}, {0.55f, 0.45f, 0.4f}, {0.75f, 0.5f, 0.45f}};
    const float corner = 13.f;  // east/west rows leave the corners to the south/north rows
    const float start = hw_ + S_ + ((side & 1) ? corner : 0), end = P_ - hw_ - S_ - ((side & 1) ? corner : 0);
    const Frame f = frame(side, S_);
    float u = start;
    while (end - u > 4) {
      float w = float(rng_.uniform(7, 15));
      if (end - (u + w) < 6) w = end - u;
      if (rng_.chance(0.1)) {  // a gap with a tree and a low wall
        tree(f.at(u + 0.5f * w, 3.f, 0.15f), 1.f);
        frame_box(f, u, u + w, 0.2f, 0.5f, 0.15f, 1.1f, kerb_);
        u += w;
        continue;
      }
      const float depth = float(rng_.uniform(8, 12));
      const float setbacks[] = {0, 0, 0.4f, 1.2f};
      const float sb = setbacks[rng_.range(0, 3)];
      const double r = rng_.uniform();
      const int storeys = 2 + int(r * r * 9);
      const float H = float(rng_.uniform(3.0, 3.5)), height = storeys * H + 0.5f;
      const V3f wall = walls[rng_.range(0, 7)];
      const uint32_t fseed = seed();
      const Material fac = make_material(MaterialKind::Facade, wall, {0.2f, 0.22f, 0.25f}, H, fseed, float(rng_.uniform(2.4, 3.8)));
      const auto fm = b_.add_material(fac);
      frame_box(f, u, u + w, sb, sb + depth, 0.15f, height, fm);
      const auto ledge = b_.add_material(make_material(MaterialKind::Concrete, fac.a * 0.8f, {0, 0, 0}, 0.8f, seed()));
      frame_box(f, u, u + w, sb - 0.25f, sb + depth, height, height + 0.35f, ledge);
      if (rng_.chance(0.3)) {
        const V3f c = walls[rng_.range(0, 7)] * 0.8f;
        const auto awning = b_.add_material(make_material(MaterialKind::Fabric, c, {0.9f, 0.88f, 0.8f}, 0.5f, seed()));
        frame_box(f, u + 1, u + w - 1, sb - 1.3f, sb, 2.7f, 2.85f, awning);
      }
      u += w;
    }
  }

  void park() {
    const float i0 = hw_ + S_ + 2, i1 = P_ - hw_ - S_ - 2;
    const int n = rng_.range(8, 14);
    for (int k = 0; k < n; ++k) {
      // One draw per statement: argument evaluation order is unspecified in C++.
      const float x = float(rng_.uniform(i0, i1));
      const float y = float(rng_.uniform(i0, i1));
      const float size = float(rng_.uniform(0.9, 1.4));
      tree(V3f(x, y, 0.15f), size);
    }
    const float mid = 0.5f * P_ + float(rng_.uniform(-5, 5));
    b_.box({i0 - 2, mid - 1.2f, 0.15f}, {i1 + 2, mid + 1.2f, 0.17f}, paving_);
    const auto wood = b_.add_material(make_material(MaterialKind::Wood, {0.55f, 0.4f, 0.25f}, {0.3f, 0.2f, 0.1f}, 0.12f, seed()));
    for (int k = 0; k < 3; ++k) {
      const float x = float(rng_.uniform(i0, i1));
      b_.box({x, mid + 1.4f, 0.15f}, {x + 1.8f, mid + 1.9f, 0.6f}, wood);
    }
  }

  void tree(const V3f& base, float size) {
    const float trunk_h = float(rng_.uniform(2.4, 3.2)) * size;
    b_.prism(base, 0.17f * size, 0.12f * size, trunk_h + 0.6f, 7, bark_);
    const float rx = float(rng_.uniform(1.5, 2.1)) * size, rz = float(rng_.uniform(1.4, 2.0)) * size;
    const float ry = rx * float(rng_.uniform(0.85, 1.15));
    const uint32_t bseed = seed();
    const uint16_t leaves = leaves_[rng_.range(0, 1)];
    b_.blob(base + V3f(0, 0, trunk_h + 0.8f * rz), rx, ry, rz, 0.18f, bseed, leaves);
  }

  // Street furniture on the sidewalk ring, away from the corners: trees near the kerb, lamps, bins.
  void sidewalk_props(int side) {
    const Frame f = frame(side, 0);  // d = 0 at the kerb, into the sidewalk
    const float u0 = hw_ + 4, u1 = P_ - hw_ - 4;
    for (float u = u0 + float(rng_.uniform(0, 3)); u < u1; u += float(rng_.uniform(9, 13)))
      if (rng_.chance(0.65)) tree(f.at(u, 0.9f, 0.15f), 1.f);
    const float lamp_u = float(rng_.uniform(u0, u1));
    const V3f lb = f.at(lamp_u, 0.35f, 0.15f);
    b_.prism(lb, 0.08f, 0.06f, 6.0f, 6, metal_);
    const V3f arm0 = f.at(lamp_u, 0.35f, 5.88f), arm1 = f.at(lamp_u, -1.2f, 6.0f);
    b_.box(arm0.cwiseMin(arm1) - V3f(0.05f, 0.05f, 0), arm0.cwiseMax(arm1) + V3f(0.05f, 0.05f, 0), metal_);
    const V3f head = f.at(lamp_u, -1.2f, 5.75f);
    b_.box(head - V3f(0.25f, 0.25f, 0), head + V3f(0.25f, 0.25f, 0.25f), metal_, false);
    for (int k = 0; k < 2; ++k) {
      if (!rng_.chance(0.5)) continue;
      const float u = float(rng_.uniform(u0, u1));
      const V3f c = V3f(0.2f, 0.4f, 0.25f) * float(rng_.uniform(0.7, 1.3));
      const auto bin = b_.add_material(make_material(MaterialKind::Paint, c, c * 0.5f, 1, seed()));
      b_.oriented_box(f.at(u, 0.6f, 0.15f), 0.55f, 0.55f, 0.95f, float(rng_.uniform(0, 0.3)), bin);
    }
    if (rng_.chance(0.35)) {  // a sign with a poster: strong texture at eye height
      const float u = float(rng_.uniform(u0, u1));
      const V3f p = f.at(u, 0.5f, 0.15f);
      b_.prism(p, 0.05f, 0.05f, 2.2f, 5, metal_);
      const auto art = b_.add_material(make_material(MaterialKind::Poster, {0, 0, 0}, {0, 0, 0}, 0.5f, seed()));
      frame_box(f, u - 0.6f, u + 0.6f, 0.44f, 0.5f, 2.2f, 3.0f, art);
    }
  }

  void car(const V3f& centre, float yaw) {
    static const V3f paints[] = {{0.7f, 0.05f, 0.05f}, {0.1f, 0.2f, 0.5f}, {0.85f, 0.85f, 0.85f}, {0.22f, 0.22f, 0.25f},
                                 {0.5f, 0.52f, 0.55f}, {0.2f, 0.4f, 0.25f}, {0.8f, 0.6f, 0.1f}};
    const V3f c = paints[rng_.range(0, 6)];
    const auto body = b_.add_material(make_material(MaterialKind::Paint, c, c * 0.6f, 1, seed()));
    const float len = float(rng_.uniform(3.9, 4.6));
    const Eigen::Vector3f ax(std::cos(yaw), std::sin(yaw), 0), ay(-std::sin(yaw), std::cos(yaw), 0);
    b_.oriented_box(centre + V3f(0, 0, 0.3f), len, 1.75f, 0.75f, yaw, body);
    b_.oriented_box(centre - 0.15f * len * ax + V3f(0, 0, 1.05f), 0.55f * len, 1.55f, 0.5f, yaw, glass_);
    for (float sx : {-0.32f, 0.32f})
      for (float sy : {-0.8f, 0.8f}) b_.oriented_box(centre + sx * len * ax + sy * ay, 0.65f, 0.22f, 0.62f, yaw, tyre_);
  }

  // Parking lanes of the block's own roads (south road along x, west road along y), clear of the
  // intersections so that turning cars never meet them.
  void parked_cars() {
    const float lane = hw_ - 1.0f;
    for (float u = hw_ + 8; u < P_ - hw_ - 8; u += 5.5f) {
      if (rng_.chance(0.45)) car(V3f(u, -lane, 0), 0);
      if (rng_.chance(0.45)) car(V3f(u, lane, 0), float(M_PI));
      if (rng_.chance(0.45)) car(V3f(-lane, u, 0), float(M_PI / 2));
      if (rng_.chance(0.45)) car(V3f(lane, u, 0), float(-M_PI / 2));
    }
  }

  const StreetOptions& o_;
  Rng rng_;
  Mesh m_;
  MeshBuilder b_;
  float P_, hw_, S_;
  bool park_;
  uint16_t asphalt_ = 0, kerb_ = 0, paving_ = 0, grass_ = 0, bark_ = 0, leaves_[2] = {0, 0}, metal_ = 0, glass_ = 0,
           tyre_ = 0;
};

}  // namespace

Mesh build_street_block(const StreetOptions& opt, int bx, int by) { return BlockBuilder(opt, bx, by).build(); }

}  // namespace chungs::synth
