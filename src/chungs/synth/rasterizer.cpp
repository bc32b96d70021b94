#include "chungs/synth/rasterizer.hpp"

#include "chungs/synth/noise.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <omp.h>

namespace chungs::synth {
namespace {

constexpr uint32_t kNone = 0xffffffffu;
constexpr int kBandRows = 8;      // rows per parallel work item of the visibility pass
constexpr size_t kChunk = 4096;   // faces per setup work item (fixed, so output order is thread-independent)

using V3 = Eigen::Vector3d;

// Intersection of segment p-q with the plane z = zc, computed from the endpoints in a canonical
// order so that two triangles sharing the edge get bit-identical points (no cracks).
V3 clip_point(const V3& p, const V3& q, double zc) {
  const bool swap = std::lexicographical_compare(q.data(), q.data() + 3, p.data(), p.data() + 3);
  const V3& a = swap ? q : p;
  const V3& b = swap ? p : q;
  double t = (zc - a.z()) / (b.z() - a.z());
  V3 r = a + t * (b - a);
  r.z() = zc;
  return r;
}

struct Edge {
  double a, b, c;  // inside where a*x + b*y + c >= 0
};

// Edge coefficients from a canonical endpoint order: shared edges give exactly negated
// coefficients, hence identical per-row bounds in both triangles.
Edge make_edge(double px, double py, double qx, double qy) {
  bool swap = (qx < px) || (qx == px && qy < py);
  if (swap) {
    std::swap(px, qx);
    std::swap(py, qy);
  }
  Edge e{py - qy, qx - px, px * qy - qx * py};
  if (swap) e = {-e.a, -e.b, -e.c};
  return e;
}

}  // namespace

void Rasterizer::render(const std::vector<const Mesh*>& meshes, const Camera& cam, const SE3& T_wc,
                        const Environment& env, const RenderOptions& opt, ImageF& rgb, ImageF& depth,
                        RenderStats* stats) {
  cam.validate("synthetic render camera");
  width_ = cam.width;
  height_ = cam.height;
  setup_triangles(meshes, cam, T_wc, opt);
  rasterize(opt);
  if (depth.width() != width_ || depth.height() != height_ || depth.channels() != 1)
    depth = ImageF(width_, height_, 1);
  const size_t n = size_t(width_) * height_;
  float* d = depth.data();
  for (size_t i = 0; i < n; ++i) d[i] = face_id_[i] == kNone ? 0.f : zbuf_[i];
  if (opt.color) shade(meshes, cam, T_wc, env, opt, rgb);
  if (stats) {
    stats->meshes = meshes.size();
    stats->triangles_in = 0;
    for (const Mesh* m : meshes) stats->triangles_in += m->triangles();
    stats->triangles_drawn = tris_.size();
  }
}

void Rasterizer::setup_triangles(const std::vector<const Mesh*>& meshes, const Camera& cam, const SE3& T_wc,
                                 const RenderOptions& opt) {
  const Eigen::Matrix3d R_cw = T_wc.rotation().transpose();
  const double W = cam.width, H = cam.height;
  // Side planes of the view pyramid through the camera centre (inside: n . p >= 0), at the outer
  // pixel edges.
  const V3 planes[4] = {V3(cam.fx, 0, cam.cx + 0.5), V3(-cam.fx, 0, W - 0.5 - cam.cx), V3(0, cam.fy, cam.cy + 0.5),
                        V3(0, -cam.fy, H - 0.5 - cam.cy)};
  auto outside = [&](const V3* p, int n) {
    bool all_near = true, all_far = true;
    for (int i = 0; i < n; ++i) {
      all_near &= p[i].z() < opt.near;
      all_far &= p[i].z() > opt.far;
    }
    if (all_near || all_far) return true;
    for (const V3& pl : planes) {
      bool all_out = true;
      for (int i = 0; i < n && all_out; ++i) all_out = pl.dot(p[i]) < 0;
      if (all_out) return true;
    }
    return false;
  };

  // Work items: (mesh, first face) for meshes whose bounds touch the view.
  struct Item {
    uint32_t mesh;
    size_t f0, f1;
  };
  std::vector<Item> items;
  for (uint32_t m = 0; m < meshes.size(); ++m) {
    const Mesh& mesh = *meshes[m];
    if (mesh.faces.empty()) continue;
    V3 corners[8];
    const V3 lo = mesh.world_lo(), hi = mesh.world_hi();
    for (int k = 0; k < 8; ++k) {
      V3 c((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
      corners[k] = R_cw * (c - T_wc.t);
    }
    if (outside(corners, 8)) continue;
    for (size_t f = 0; f < mesh.faces.size(); f += kChunk)
      items.push_back({m, f, std::min(f + kChunk, mesh.faces.size())});
  }

  // Each thread appends its items' triangles to a buffer of its own and notes where each item's
  // went; they are gathered in item order afterwards. Buffers per thread, not per item: a buffer
  // per item kept the largest output each item index ever had, and over a long drive the sum of
  // those maxima kept growing.
  const size_t threads = size_t(std::max(1, omp_get_max_threads()));
  thread_tris_.resize(threads);
  for (auto& b : thread_tris_) b.clear();
  item_spans_.resize(items.size());
  const double fx = cam.fx, fy = cam.fy, cx = cam.cx, cy = cam.cy;
#pragma omp parallel for schedule(dynamic, 1)
  for (long it = 0; it < long(items.size()); ++it) {
    const Item& item = items[it];
    const Mesh& mesh = *meshes[item.mesh];
    const size_t tid = size_t(omp_get_thread_num());
    auto& out = thread_tris_[tid];
    const size_t first = out.size();
    const Eigen::Matrix3f R = R_cw.cast<float>();
    const Eigen::Vector3f c = (R_cw * (mesh.origin - T_wc.t)).cast<float>();
    for (size_t f = item.f0; f < item.f1; ++f) {
      const auto& face = mesh.faces[f];
      V3 p[3];
      for (int k = 0; k < 3; ++k) p[k] = (R * mesh.vertices[face[k]] + c).cast<double>();
      if (outside(p, 3)) continue;
      const V3 n = (p[1] - p[0]).cross(p[2] - p[0]);
      const double nn = n.norm();
      const double d = n.dot(p[0]);
      if (!(nn > 0) || std::abs(d) <= 1e-9 * nn) continue;  // degenerate or seen edge-on
      ScreenTri st;
      st.iz_a = n.x() / (fx * d);
      st.iz_b = n.y() / (fy * d);
      st.iz_c = (n.z() - n.x() * cx / fx - n.y() * cy / fy) / d;
      st.mesh = item.mesh;
      st.face = uint32_t(f);
      // Clip against z >= near (Sutherland-Hodgman, one plane): at most 4 vertices.
      V3 poly[4];
      int np = 0;
      for (int k = 0; k < 3; ++k) {
        const V3& a = p[k];
        const V3& b = p[(k + 1) % 3];
        const bool ina = a.z() >= opt.near, inb = b.z() >= opt.near;
        if (ina) poly[np++] = a;
        if (ina != inb) poly[np++] = clip_point(a, b, opt.near);
      }
      double sx[4], sy[4];
      for (int k = 0; k < np; ++k) {
        sx[k] = fx * poly[k].x() / poly[k].z() + cx;
        sy[k] = fy * poly[k].y() / poly[k].z() + cy;
      }
      for (int k = 1; k + 1 < np; ++k) {
        const double ymin = std::min({sy[0], sy[k], sy[k + 1]}), ymax = std::max({sy[0], sy[k], sy[k + 1]});
        const double xmin = std::min({sx[0], sx[k], sx[k + 1]}), xmax = std::max({sx[0], sx[k], sx[k + 1]});
        if (xmax < 0 || xmin > W - 1 || ymax < 0 || ymin > H - 1) continue;
        st.y0 = int(std::max(0.0, std::ceil(ymin)));
        st.y1 = int(std::min(H - 1, std::floor(ymax)));
        if (st.y0 > st.y1) continue;
        st.ax = sx[0], st.ay = sy[0], st.bx = sx[k], st.by = sy[k], st.cx = sx[k + 1], st.cy = sy[k + 1];
        out.push_back(st);
      }
    }
    item_spans_[it] = {tid, first, out.size()};
  }
  tris_.clear();
  for (const ItemSpan& sp : item_spans_) {
    const auto& src = thread_tris_[sp.thread];
    tris_.insert(tris_.end(), src.begin() + long(sp.begin), src.begin() + long(sp.end));
  }
}

void Rasterizer::rasterize(const RenderOptions& opt) {
  const int W = width_, H = height_;
  const size_t n = size_t(W) * H;
  zbuf_.resize(n);
  mesh_id_.resize(n);
  face_id_.resize(n);
  const int nb = (H + kBandRows - 1) / kBandRows;
  bands_.resize(nb);
  for (auto& b : bands_) b.clear();
  for (uint32_t i = 0; i < tris_.size(); ++i)
    for (int b = tris_[i].y0 / kBandRows; b <= tris_[i].y1 / kBandRows; ++b) bands_[b].push_back(i);

  const float zmin = float(opt.near) * 0.999f, zmax = float(opt.far);

#pragma omp parallel for schedule(dynamic, 1)
  for (int b = 0; b < nb; ++b) {
    const int r0 = b * kBandRows, r1 = std::min(H, r0 + kBandRows) - 1;
    std::fill(zbuf_.begin() + size_t(r0) * W, zbuf_.begin() + size_t(r1 + 1) * W, std::numeric_limits<float>::infinity());
    std::fill(face_id_.begin() + size_t(r0) * W, face_id_.begin() + size_t(r1 + 1) * W, kNone);
    for (uint32_t ti : bands_[b]) {
      const ScreenTri& t = tris_[ti];
      Edge e[3] = {make_edge(t.ax, t.ay, t.bx, t.by), make_edge(t.bx, t.by, t.cx, t.cy),
                   make_edge(t.cx, t.cy, t.ax, t.ay)};
      const double area = e[0].a * t.cx + e[0].b * t.cy + e[0].c;
      if (area == 0) continue;
      if (area < 0)
        for (auto& ed : e) ed = {-ed.a, -ed.b, -ed.c};
      const int y0 = std::max(t.y0, r0), y1 = std::min(t.y1, r1);
      for (int y = y0; y <= y1; ++y) {
        double xl = -1, xr = W;  // bounds just outside the image
        bool empty = false;
        for (const Edge& ed : e) {
          const double v = ed.b * y + ed.c;
          if (ed.a > 0) xl = std::max(xl, -v / ed.a);
          else if (ed.a < 0) xr = std::min(xr, -v / ed.a);
          else if (v < 0) empty = true;
        }
        if (empty || xl > xr) continue;
        const int x0 = std::max(0, int(std::ceil(xl))), x1 = std::min(W - 1, int(std::floor(xr)));
        float* zrow = zbuf_.data() + size_t(y) * W;
        uint32_t* frow = face_id_.data() + size_t(y) * W;
        uint32_t* mrow = mesh_id_.data() + size_t(y) * W;
        const double base = t.iz_b * y + t.iz_c;
        for (int x = x0; x <= x1; ++x) {
          const double iz = t.iz_a * x + base;
          if (!(iz > 0)) continue;
          const float z = float(1.0 / iz);
          if (z < zrow[x] && z >= zmin && z <= zmax) {
            zrow[x] = z;
            frow[x] = t.face;
            mrow[x] = t.mesh;
          }
        }
      }
    }
  }
}

void Rasterizer::shade(const std::vector<const Mesh*>& meshes, const Camera& cam, const SE3& T_wc,
                       const Environment& env, const RenderOptions& opt, ImageF& rgb) {
  (void)opt;
  const int W = width_, H = height_;
  if (rgb.width() != W || rgb.height() != H || rgb.channels() != 3) rgb = ImageF(W, H, 3);
  const Eigen::Matrix3d R = T_wc.rotation();
  const V3 ex = R.col(0), ey = R.col(1);
  const V3 centre = T_wc.t;
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < H; ++y) {
    float* out = rgb.row(y);
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      const V3 ray_c((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0);
      const V3 rw = R * ray_c;  // world direction with unit camera-z component
      Eigen::Vector3f c;
      if (face_id_[i] == kNone) {
        c = background_color(env, rw.normalized());
      } else {
        const double z = zbuf_[i];
        const Mesh& mesh = *meshes[mesh_id_[i]];
        const uint32_t f = face_id_[i];
        const auto& face = mesh.faces[f];
        const V3 p = centre + z * rw;
        const V3 v0 = mesh.origin + mesh.vertices[face[0]].cast<double>();
        const V3 e1 = (mesh.vertices[face[1]] - mesh.vertices[face[0]]).cast<double>();
        const V3 e2 = (mesh.vertices[face[2]] - mesh.vertices[face[0]]).cast<double>();
        V3 n = e1.cross(e2).normalized();
        double ndr = n.dot(rw);
        if (ndr > 0) {
          n = -n;
          ndr = -ndr;
        }
        if (ndr > -1e-9) ndr = -1e-9;
        // Surface displacement per pixel step in u and v (exact for the plane): texture filtering.
        const V3 dpdu = z / cam.fx * (ex - rw * (n.dot(ex) / ndr));
        const V3 dpdv = z / cam.fy * (ey - rw * (n.dot(ey) / ndr));
        SurfacePoint sp;
        // Texture space: the world, or for a moving object its own frame (the pattern moves with it).
        V3 tp = p, tn = n, tdu = dpdu, tdv = dpdv;
        if (mesh.object_texture) {
          const Eigen::Matrix3d Rt = mesh.object_rotation.transpose();
          tp = Rt * (p - mesh.origin);
          tn = Rt * n;
          tdu = Rt * dpdu;
          tdv = Rt * dpdv;
        }
        sp.p = tp;
        sp.n = tn.cast<float>();
        const V3 an = tn.cwiseAbs();
        int su, tu;  // axes used as texture s and t
        if (an.z() >= an.x() && an.z() >= an.y()) su = 0, tu = 1, sp.vertical = false;
        else if (an.x() >= an.y()) su = 1, tu = 2, sp.vertical = true;
        else su = 0, tu = 2, sp.vertical = true;
        sp.s = tp[su];
        sp.t = tp[tu];
        sp.fs = std::max({std::abs(tdu[su]), std::abs(tdv[su]), 1e-6});
        sp.ft = std::max({std::abs(tdu[tu]), std::abs(tdv[tu]), 1e-6});
        const Material& mat = mesh.material_of(f);
        if (mat.kind == MaterialKind::VertexColor && !mesh.colors.empty()) {
          // Barycentric coordinates of the exact surface point: perspective-correct by construction.
          const V3 w = p - v0;
          const double d00 = e1.dot(e1), d01 = e1.dot(e2), d11 = e2.dot(e2), d20 = w.dot(e1), d21 = w.dot(e2);
          const double den = d00 * d11 - d01 * d01;
          double b1 = den != 0 ? (d11 * d20 - d01 * d21) / den : 0, b2 = den != 0 ? (d00 * d21 - d01 * d20) / den : 0;
          b1 = std::clamp(b1, 0.0, 1.0);
          b2 = std::clamp(b2, 0.0, 1.0 - b1);
          const double b0 = 1 - b1 - b2;
          Eigen::Vector3f vc = Eigen::Vector3f::Zero();
          const double bw[3] = {b0, b1, b2};
          for (int k = 0; k < 3; ++k) {
            const auto& col = mesh.colors[face[k]];
            vc += float(bw[k]) * Eigen::Vector3f(col[0], col[1], col[2]) / 255.f;
          }
          sp.vertex_color = vc;
        }
        c = shade_material(mat, sp);
        if (mat.lit) c *= env.ambient + env.diffuse * float(std::max(0.0, n.dot(env.light_dir)));
        if (env.fog_end > env.fog_start) {
          const float k = smoothstep(env.fog_start, env.fog_end, float(z * rw.norm()));
          if (k > 0) c += k * (background_color(env, rw.normalized()) - c);
        }
      }
      for (int k = 0; k < 3; ++k) out[3 * x + k] = clamp01(c[k]);
    }
  }
}

}  // namespace chungs::synth
