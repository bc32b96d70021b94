#include "chungs/synth/mesh.hpp"

#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/synth/noise.hpp"

namespace chungs::synth {

void Mesh::compute_bounds() {
  if (vertices.empty()) {
    lo = hi = Eigen::Vector3f::Zero();
    return;
  }
  lo = hi = vertices[0];
  for (const auto& v : vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
}

size_t Mesh::memory_bytes() const {
  return vertices.capacity() * sizeof(vertices[0]) + colors.capacity() * 3 + faces.capacity() * sizeof(faces[0]) +
         face_material.capacity() * 2 + materials.capacity() * sizeof(Material) + sizeof(Mesh);
}

uint16_t MeshBuilder::add_material(const Material& mat) {
  if (m_.materials.size() >= 65535) fail("synthetic mesh: more than 65535 materials in one mesh");
  m_.materials.push_back(mat);
  return uint16_t(m_.materials.size() - 1);
}

uint32_t MeshBuilder::vertex(const Eigen::Vector3f& p) {
  m_.vertices.push_back(p);
  return uint32_t(m_.vertices.size() - 1);
}

void MeshBuilder::triangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
                           uint16_t mat) {
  uint32_t i = vertex(a), j = vertex(b), k = vertex(c);
  m_.faces.push_back({i, j, k});
  m_.face_material.push_back(mat);
}

void MeshBuilder::quad(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
                       const Eigen::Vector3f& d, uint16_t mat) {
  uint32_t i = vertex(a), j = vertex(b), k = vertex(c), l = vertex(d);
  m_.faces.push_back({i, j, k});
  m_.faces.push_back({i, k, l});
  m_.face_material.push_back(mat);
  m_.face_material.push_back(mat);
}

void MeshBuilder::box(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, uint16_t mat, bool skip_bottom) {
  using V = Eigen::Vector3f;
  const float x0 = lo.x(), y0 = lo.y(), z0 = lo.z(), x1 = hi.x(), y1 = hi.y(), z1 = hi.z();
  quad(V(x0, y0, z0), V(x1, y0, z0), V(x1, y0, z1), V(x0, y0, z1), mat);  // -y
  quad(V(x1, y1, z0), V(x0, y1, z0), V(x0, y1, z1), V(x1, y1, z1), mat);  // +y
  quad(V(x0, y1, z0), V(x0, y0, z0), V(x0, y0, z1), V(x0, y1, z1), mat);  // -x
  quad(V(x1, y0, z0), V(x1, y1, z0), V(x1, y1, z1), V(x1, y0, z1), mat);  // +x
  quad(V(x0, y0, z1), V(x1, y0, z1), V(x1, y1, z1), V(x0, y1, z1), mat);  // top
  if (!skip_bottom) quad(V(x0, y1, z0), V(x1, y1, z0), V(x1, y0, z0), V(x0, y0, z0), mat);
}

void MeshBuilder::oriented_box(const Eigen::Vector3f& base, float sx, float sy, float sz, float yaw, uint16_t mat) {
  const Eigen::Vector3f ex(std::cos(yaw) * 0.5f * sx, std::sin(yaw) * 0.5f * sx, 0);
  const Eigen::Vector3f ey(-std::sin(yaw) * 0.5f * sy, std::cos(yaw) * 0.5f * sy, 0);
  const Eigen::Vector3f up(0, 0, sz);
  const Eigen::Vector3f c[4] = {base - ex - ey, base + ex - ey, base + ex + ey, base - ex + ey};
  for (int i = 0; i < 4; ++i) {
    const auto& p = c[i];
    const auto& q = c[(i + 1) % 4];
    quad(p, q, q + up, p + up, mat);
  }
  quad(c[0] + up, c[1] + up, c[2] + up, c[3] + up, mat);
}

void MeshBuilder::prism(const Eigen::Vector3f& base, float r0, float r1, float height, int sides, uint16_t mat) {
  const float step = 2 * float(M_PI) / float(sides);
  const Eigen::Vector3f top = base + Eigen::Vector3f(0, 0, height);
  for (int i = 0; i < sides; ++i) {
    Eigen::Vector3f d0(std::cos(i * step), std::sin(i * step), 0), d1(std::cos((i + 1) * step), std::sin((i + 1) * step), 0);
    if (r1 > 0) {
      quad(base + r0 * d0, base + r0 * d1, top + r1 * d1, top + r1 * d0, mat);
      triangle(top + r1 * d0, top + r1 * d1, top, mat);
    } else {
      triangle(base + r0 * d0, base + r0 * d1, top, mat);  // cone
    }
  }
}

void MeshBuilder::blob(const Eigen::Vector3f& centre, float rx, float ry, float rz, float lumps, uint32_t seed,
                       uint16_t mat) {
  constexpr int kAz = 8, kEl = 5;
  // Grid of (kEl - 1) rings plus two poles; vertices are shared so the lumps stay watertight.
  auto point = [&](int ring, int az) {
    float el = float(M_PI) * (float(ring) / kEl - 0.5f);
    float a = 2 * float(M_PI) * float(az % kAz) / kAz + 0.3f * float(ring);
    float r = 1 + lumps * (2 * hash01(ring, az % kAz, seed) - 1);
    return Eigen::Vector3f(centre.x() + rx * r * std::cos(el) * std::cos(a), centre.y() + ry * r * std::cos(el) * std::sin(a),
                           centre.z() + rz * r * std::sin(el));
  };
  const uint32_t base = uint32_t(m_.vertices.size());
  m_.vertices.push_back(centre - Eigen::Vector3f(0, 0, rz * (1 - lumps)));  // south pole
  for (int ring = 1; ring < kEl; ++ring)
    for (int az = 0; az < kAz; ++az) m_.vertices.push_back(point(ring, az));
  m_.vertices.push_back(centre + Eigen::Vector3f(0, 0, rz * (1 + lumps)));  // north pole
  auto idx = [&](int ring, int az) { return base + 1 + uint32_t((ring - 1) * kAz + (az % kAz)); };
  const uint32_t south = base, north = base + 1 + uint32_t((kEl - 1) * kAz);
  auto face = [&](uint32_t i, uint32_t j, uint32_t k) {
    m_.faces.push_back({i, j, k});
    m_.face_material.push_back(mat);
  };
  for (int az = 0; az < kAz; ++az) {
    face(south, idx(1, az + 1), idx(1, az));
    face(idx(kEl - 1, az), idx(kEl - 1, az + 1), north);
    for (int ring = 1; ring < kEl - 1; ++ring) {
      face(idx(ring, az), idx(ring, az + 1), idx(ring + 1, az + 1));
      face(idx(ring, az), idx(ring + 1, az + 1), idx(ring + 1, az));
    }
  }
}

}  // namespace chungs::synth
