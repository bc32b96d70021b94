#include "chungs/synth/scene.hpp"

namespace chungs::synth {

bool box_maybe_visible(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Camera& cam, const SE3& T_wc,
                       double far) {
  const Eigen::Matrix3d R_cw = T_wc.rotation().transpose();
  // Planes through the camera centre bounding the view pyramid (inside: n . p >= 0), then z <= far.
  const Eigen::Vector3d planes[4] = {{cam.fx, 0, cam.cx + 0.5},
                                     {-cam.fx, 0, cam.width - 0.5 - cam.cx},
                                     {0, cam.fy, cam.cy + 0.5},
                                     {0, -cam.fy, cam.height - 0.5 - cam.cy}};
  Eigen::Vector3d c[8];
  for (int k = 0; k < 8; ++k)
    c[k] = R_cw * (Eigen::Vector3d((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z()) -
                   T_wc.t);
  bool all_behind = true, all_far = true;
  for (const auto& p : c) {
    all_behind &= p.z() < 0;
    all_far &= p.z() > far;
  }
  if (all_behind || all_far) return false;
  for (const auto& pl : planes) {
    bool out = true;
    for (const auto& p : c) out &= pl.dot(p) < 0;
    if (out) return false;
  }
  return true;
}

std::vector<const Mesh*> MeshScene::gather(const Camera& cam, const SE3& T_wc, double far) {
  std::vector<const Mesh*> out;
  for (const Mesh& m : meshes_)
    if (box_maybe_visible(m.world_lo(), m.world_hi(), cam, T_wc, far)) out.push_back(&m);
  return out;
}

size_t MeshScene::triangles() const {
  size_t n = 0;
  for (const Mesh& m : meshes_) n += m.triangles();
  return n;
}

}  // namespace chungs::synth
