// Neighbour keyframes for the plane sweep (plane_sweep.hpp): overlap times a triangulation-angle score.
#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/depth/plane_sweep.hpp"

namespace chungs {

std::vector<size_t> select_sweep_neighbours(const Camera& camera, const std::vector<SE3>& poses, size_t ref,
                                            const NeighbourChoice& c) {
  camera.validate("sweep neighbour camera");
  if (ref >= poses.size()) fail("sweep neighbours: reference ", ref, " of ", poses.size(), " poses");
  if (!(std::isfinite(c.scene_depth) && c.scene_depth > 0)) fail("sweep neighbours: scene_depth ", c.scene_depth);
  if (!(c.min_angle_deg >= 0 && c.target_angle_deg > c.min_angle_deg && c.target_angle_deg < 90))
    fail("sweep neighbours: angles ", c.min_angle_deg, " and ", c.target_angle_deg, " degrees");
  if (!(c.max_axis_angle_deg > 0 && c.max_axis_angle_deg <= 180))
    fail("sweep neighbours: max_axis_angle_deg ", c.max_axis_angle_deg);
  if (!(c.min_overlap >= 0 && c.min_overlap <= 1)) fail("sweep neighbours: min_overlap ", c.min_overlap);

  // A grid of reference pixels at the scene depth stands for what the reference sees.
  constexpr int kGrid = 8;
  std::vector<Eigen::Vector3d> points;
  const SE3& Tr = poses[ref];
  for (int gy = 0; gy < kGrid; ++gy)
    for (int gx = 0; gx < kGrid; ++gx) {
      const Eigen::Vector2d px((gx + 0.5) * camera.width / kGrid, (gy + 0.5) * camera.height / kGrid);
      points.push_back(Tr * camera.unproject(px, c.scene_depth));
    }
  const double deg = M_PI / 180.0;
  const Eigen::Vector3d axis_r = Tr.rotation().col(2);
  struct Scored { double score; size_t index; };
  std::vector<Scored> scored;
  for (size_t j = 0; j < poses.size(); ++j) {
    if (j == ref) continue;
    const SE3& Tj = poses[j];
    if (!Tj.t.allFinite() || !Tj.q.coeffs().allFinite()) fail("sweep neighbours: pose ", j, " is not finite");
    const double axis = std::acos(std::clamp(axis_r.dot(Tj.rotation().col(2)), -1.0, 1.0));
    if (axis > c.max_axis_angle_deg * deg) continue;
    const SE3 Tjw = Tj.inverse();
    // Overlap, and the mean angle the baseline subtends at the points both see: forward motion has
    // none at the image centre but plenty towards the borders.
    int seen = 0;
    double angle_sum = 0;
    for (const auto& X : points) {
      const Eigen::Vector3d pc = Tjw * X;
      if (!(pc.z() > 1e-6 && camera.in_image(camera.project(pc)))) continue;
      ++seen;
      const Eigen::Vector3d a = (Tr.t - X).normalized(), b = (Tj.t - X).normalized();
      angle_sum += std::acos(std::clamp(a.dot(b), -1.0, 1.0));
    }
    const double overlap = double(seen) / double(points.size());
    if (overlap < c.min_overlap || seen == 0) continue;
    const double angle = angle_sum / seen;
    if (!(angle >= c.min_angle_deg * deg)) continue;
    const double target = c.target_angle_deg * deg;
    const double fit = angle <= target ? angle / target : target / angle;
    scored.push_back({overlap * fit, j});
  }
  std::stable_sort(scored.begin(), scored.end(), [](const Scored& x, const Scored& y) { return x.score > y.score; });
  std::vector<size_t> out;
  for (size_t i = 0; i < scored.size() && i < c.count; ++i) out.push_back(scored[i].index);
  return out;
}

}  // namespace chungs
