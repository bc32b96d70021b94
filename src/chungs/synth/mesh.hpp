// Triangle meshes for the synthetic renderer: positions relative to a per-mesh origin (so a 10 km
// world keeps float precision), optional per-vertex colours, and a material per face.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace chungs::synth {

// How a face is coloured. Procedural kinds are functions of the world-space surface point; see
// materials.hpp for what each draws and what `scale` and `param` mean for it.
enum class MaterialKind : uint8_t {
  VertexColor,  // interpolated vertex colours (scanned meshes), unlit
  Flat,         // colour a with mild multi-scale noise
  Plaster,      // painted wall: a with blotches towards b
  Wallpaper,    // vertical stripes a/b with small motifs, period scale
  Brick,        // bricks a, mortar b, brick height scale
  Facade,       // building wall a with window grid (glass b), storey height scale, window period param
  Wood,         // planks of width scale, light a, dark b
  Fabric,       // tartan of a and b, check size scale
  Tiles,        // square tiles a, joints b, tile size scale
  Asphalt,      // road surface with lane markings; scale = road width, param = street grid pitch
  Paving,       // sidewalk slabs a, joints b, slab size scale
  Concrete,     // grey a with formwork panels of size scale
  Grass,        // greens a/b
  Foliage,      // leaves a/b, blob size scale
  Bark,         // brown streaks
  Paint,        // smooth coloured surface (cars, furniture) a, fine grain b
  Glass,        // dark reflective a with sky-coloured streaks b
  Poster,       // recursive coloured rectangles (paintings, billboards), cell size scale
  Books,        // book spines of random widths/colours; shelf height scale
};

struct Material {
  MaterialKind kind = MaterialKind::Flat;
  Eigen::Vector3f a{0.6f, 0.6f, 0.6f}, b{0.3f, 0.3f, 0.3f};
  float scale = 1.f;
  float param = 0.f;
  uint32_t seed = 0;
  bool lit = true;  // multiply by the environment's light (false for pre-lit vertex colours)
};

inline Material make_material(MaterialKind kind, const Eigen::Vector3f& a, const Eigen::Vector3f& b, float scale,
                              uint32_t seed, float param = 0) {
  Material m;
  m.kind = kind;
  m.a = a;
  m.b = b;
  m.scale = scale;
  m.seed = seed;
  m.param = param;
  return m;
}

struct Mesh {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // world position of local (0, 0, 0)
  std::vector<Eigen::Vector3f> vertices;             // local coordinates
  std::vector<std::array<uint8_t, 3>> colors;        // per vertex RGB, or empty
  std::vector<std::array<uint32_t, 3>> faces;
  std::vector<uint16_t> face_material;  // per face, index into materials; empty means material 0
  std::vector<Material> materials;      // at least one when the mesh has faces
  Eigen::Vector3f lo{0, 0, 0}, hi{0, 0, 0};  // local bounds of the vertices
  // A moving object (a car in traffic) carries its texture with it: when set, materials are evaluated
  // in the object's frame, at object_rotation^T * (p - origin), instead of at the world point p.
  bool object_texture = false;
  Eigen::Matrix3d object_rotation = Eigen::Matrix3d::Identity();

  size_t triangles() const { return faces.size(); }
  const Material& material_of(size_t face) const {
    return materials[face_material.empty() ? 0 : face_material[face]];
  }
  void compute_bounds();
  Eigen::Vector3d world_lo() const { return origin + lo.cast<double>(); }
  Eigen::Vector3d world_hi() const { return origin + hi.cast<double>(); }
  size_t memory_bytes() const;
};

// Appends primitives to a mesh; positions are local to the mesh origin. Winding is outward where
// it matters (the renderer draws both sides).
class MeshBuilder {
 public:
  explicit MeshBuilder(Mesh& m) : m_(m) {}
  uint16_t add_material(const Material& mat);
  void triangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c, uint16_t mat);
  // Quad a-b-c-d in order around its boundary.
  void quad(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c, const Eigen::Vector3f& d,
            uint16_t mat);
  // Axis-aligned box; `skip_bottom` leaves out the face at lo.z (resting on the ground).
  void box(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, uint16_t mat, bool skip_bottom = true);
  // Box of size (sx, sy, sz) standing on `base` (centre of its bottom face), turned by `yaw` about z.
  void oriented_box(const Eigen::Vector3f& base, float sx, float sy, float sz, float yaw, uint16_t mat);
  // Vertical prism with `sides` sides (a cylinder), radius r0 at the bottom and r1 at the top.
  void prism(const Eigen::Vector3f& base, float r0, float r1, float height, int sides, uint16_t mat);
  // Lumpy ellipsoid (tree crowns, bushes): radii (rx, ry, rz), vertices displaced by `lumps` * r
  // using `seed`; 8 x 5 segments.
  void blob(const Eigen::Vector3f& centre, float rx, float ry, float rz, float lumps, uint32_t seed, uint16_t mat);

 private:
  uint32_t vertex(const Eigen::Vector3f& p);
  Mesh& m_;
};

}  // namespace chungs::synth
