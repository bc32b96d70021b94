// A brute-force reference renderer for the tests, written independently of the tiled one with Eigen:
// every pixel composites every Gaussian in depth order, with the same cut-off rules (alpha skip,
// extent cut, alpha clamp, transmittance stop) and the same pixel-centre convention.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_output.hpp"
#include "chungs/render/sh.hpp"
#include "random_scene.hpp"

namespace chungs::test {

struct RefSplat {
  Eigen::Vector2d mean;
  Eigen::Matrix2d conic;
  double opacity, z, power_min;
  Eigen::Vector3d color;
  uint32_t slot;
};

inline RenderOutput<double> reference_render(const SceneArrays<double>& g, const std::vector<uint32_t>& ids,
                                             const Camera& cam, const SE3& T_wc, const RasterConfig& cfg) {
  const SE3 T_cw = T_wc.inverse();
  const Eigen::Matrix3d W = T_cw.rotation();
  std::vector<RefSplat> splats;
  for (uint32_t slot : ids) {
    const Eigen::Vector3d pw(g.mean[3 * slot], g.mean[3 * slot + 1], g.mean[3 * slot + 2]);
    const Eigen::Vector3d pc = T_cw * pw;
    if (pc.z() < cfg.near_plane) continue;
    Eigen::Quaterniond q(g.rotation[4 * slot], g.rotation[4 * slot + 1], g.rotation[4 * slot + 2],
                         g.rotation[4 * slot + 3]);
    q.normalize();
    const Eigen::Vector3d s(std::exp(g.log_scale[3 * slot]), std::exp(g.log_scale[3 * slot + 1]),
                            std::exp(g.log_scale[3 * slot + 2]));
    const Eigen::Matrix3d M = q.toRotationMatrix() * s.asDiagonal();
    const Eigen::Matrix3d Sigma = M * M.transpose();
    const double z = pc.z();
    const double lo_x = (cam.width / 2.0 * (1 - cfg.guard_band) - cam.cx) / cam.fx;
    const double hi_x = (cam.width / 2.0 * (1 + cfg.guard_band) - cam.cx) / cam.fx;
    const double lo_y = (cam.height / 2.0 * (1 - cfg.guard_band) - cam.cy) / cam.fy;
    const double hi_y = (cam.height / 2.0 * (1 + cfg.guard_band) - cam.cy) / cam.fy;
    const double rx = std::clamp(pc.x() / z, lo_x, hi_x), ry = std::clamp(pc.y() / z, lo_y, hi_y);
    Eigen::Matrix<double, 2, 3> J;
    J << cam.fx / z, 0, -cam.fx * rx / z, 0, cam.fy / z, -cam.fy * ry / z;
    const double low_pass = cfg.low_pass_for(cam.width, cam.height);
    const Eigen::Matrix2d cov =
        J * W * Sigma * W.transpose() * J.transpose() + low_pass * Eigen::Matrix2d::Identity();
    RefSplat r;
    r.mean = cam.project(pc);
    r.conic = cov.inverse();
    r.opacity = 1 / (1 + std::exp(-g.opacity[slot]));
    // The anti-aliased low-pass keeps a splat's weight: opacity x sqrt(det without / det with it).
    if (cfg.antialias)
      r.opacity *= std::sqrt(
          std::max(0.0, (cov - low_pass * Eigen::Matrix2d::Identity()).determinant() / cov.determinant()));
    r.z = z;
    r.power_min = -0.5 * cfg.extent_sigma * cfg.extent_sigma;
    if (cfg.min_alpha > 0) r.power_min = std::max(r.power_min, std::log(cfg.min_alpha / r.opacity));
    const Eigen::Vector3d dir = (pw - T_wc.t).normalized();
    double b[kShCoeffs];
    sh::basis(cfg.sh_degree, dir.x(), dir.y(), dir.z(), b);
    for (int c = 0; c < 3; ++c) {
      double v = 0.5;
      for (int k = 0; k < sh_coeffs_for_degree(cfg.sh_degree); ++k)
        v += b[k] * g.sh[size_t(kShFloats) * slot + 3 * k + c];
      r.color[c] = std::max(v, 0.0);
    }
    r.slot = slot;
    splats.push_back(r);
  }
  std::stable_sort(splats.begin(), splats.end(),
                   [](const RefSplat& a, const RefSplat& b) { return float(a.z) < float(b.z); });

  RenderOutput<double> out{Image<double>(cam.width, cam.height, 3),
                           Image<double>(cam.width, cam.height),
                           Image<double>(cam.width, cam.height),
                           Image<double>(cam.width, cam.height),
                           Image<uint32_t>(cam.width, cam.height),
                           {},
                           {}};
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      double T = 1, best_w = 0;
      Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
      double depth = 0, inv = 0;
      uint32_t best = kNoGaussian;
      for (const RefSplat& s : splats) {
        const Eigen::Vector2d d = Eigen::Vector2d(x, y) - s.mean;
        const double power = -0.5 * d.dot(s.conic * d);
        if (power < s.power_min) continue;
        const double alpha = std::min(cfg.alpha_max, s.opacity * std::exp(power));
        if (T * (1 - alpha) < cfg.min_transmittance) break;
        const double w = alpha * T;
        rgb += w * s.color;
        depth += w * s.z;
        inv += w / s.z;
        if (w > best_w) best_w = w, best = s.slot;
        T *= 1 - alpha;
      }
      for (int c = 0; c < 3; ++c) out.rgb(x, y, c) = rgb[c] + T * cfg.background[c];
      out.depth(x, y) = depth;
      out.inv_depth(x, y) = inv;
      out.alpha(x, y) = 1 - T;
      out.top_id(x, y) = best;
    }
  return out;
}

}  // namespace chungs::test
