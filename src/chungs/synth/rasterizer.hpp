// CPU triangle rasterizer for synthetic frames. Two passes: a visibility pass (z-buffer of mesh and
// face ids, rows binned into bands rendered in parallel) and a shading pass that evaluates each
// visible pixel once, from the exact ray-surface point. Pixel (u, v) samples the ray through pixel
// coordinates (u, v) (centres at integers); depth is z along the optical axis, 0 where nothing was
// hit. Triangles crossing the near plane are clipped, not dropped. Output is deterministic for any
// thread count.
#pragma once
#include <cstdint>
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/image/image.hpp"
#include "chungs/synth/materials.hpp"
#include "chungs/synth/mesh.hpp"

namespace chungs::synth {

struct RenderOptions {
  double near = 0.05;  // metres
  double far = 150.0;  // metres; surfaces beyond are not drawn
  bool color = true;   // false: depth only (skips the shading pass)
};

struct RenderStats {
  size_t meshes = 0;          // meshes submitted
  size_t triangles_in = 0;    // faces of those meshes
  size_t triangles_drawn = 0; // screen triangles after culling and clipping
};

class Rasterizer {
 public:
  // Renders `meshes` (world-space, each with its origin) seen by `cam` (distortion is ignored) at
  // camera-to-world pose `T_wc`. rgb gets 3 channels in [0, 1]; depth 1 channel in metres.
  void render(const std::vector<const Mesh*>& meshes, const Camera& cam, const SE3& T_wc, const Environment& env,
              const RenderOptions& opt, ImageF& rgb, ImageF& depth, RenderStats* stats = nullptr);

  struct ScreenTri {
    double ax, ay, bx, by, cx, cy;  // projected vertices, pixels (after near clipping)
    double iz_a, iz_b, iz_c;        // 1/z = iz_a * u + iz_b * v + iz_c over the triangle's plane
    int y0, y1;                     // rows covered (clamped to the image)
    uint32_t mesh, face;
  };

 private:
  void setup_triangles(const std::vector<const Mesh*>& meshes, const Camera& cam, const SE3& T_wc,
                       const RenderOptions& opt);
  void rasterize(const RenderOptions& opt);
  void shade(const std::vector<const Mesh*>& meshes, const Camera& cam, const SE3& T_wc, const Environment& env,
             const RenderOptions& opt, ImageF& rgb);

  // Work buffers kept between calls to avoid reallocating them every frame.
  std::vector<ScreenTri> tris_;
  struct ItemSpan {
    size_t thread, begin, end;  // an item's triangles: thread_tris_[thread][begin, end)
  };
  std::vector<std::vector<ScreenTri>> thread_tris_;
  std::vector<ItemSpan> item_spans_;
  std::vector<std::vector<uint32_t>> bands_;
  std::vector<float> zbuf_;
  std::vector<uint32_t> mesh_id_, face_id_;
  int width_ = 0, height_ = 0;
};

}  // namespace chungs::synth
