#include "chungs/depth/plane_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "chungs/common/error.hpp"
#include "chungs/depth/plane_sweep_problem.hpp"
#ifdef CHUNGS_WITH_CUDA
#include "chungs/depth/cuda/plane_sweep_cuda.hpp"
#endif

namespace chungs {

namespace ps = plane_sweep;

void PlaneSweepConfig::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (patch_radius < 1 || patch_radius > ps::kMaxPatchRadius)
    fail("plane sweep: patch_radius ", patch_radius, " (1 to ", ps::kMaxPatchRadius, ")");
  if (best_k < 1 || best_k > ps::kMaxNeighbours) fail("plane sweep: best_k ", best_k, " (1 to ", ps::kMaxNeighbours, ")");
  if (min_views < 1 || min_views > best_k) fail("plane sweep: min_views ", min_views, " (1 to best_k, ", best_k, ")");
  if (!positive(near) || !positive(far) || !(far > near)) fail("plane sweep: near ", near, " and far ", far, " m");
  if (!(prior_range > 0 && prior_range < 1)) fail("plane sweep: prior_range ", prior_range, " (between 0 and 1)");
  if (!(prior_abs_range >= 0) || !std::isfinite(prior_abs_range))
    fail("plane sweep: prior_abs_range ", prior_abs_range, " (0: off, else a positive inverse depth)");
  if (!(min_prior_confidence >= 0 && min_prior_confidence <= 1))
    fail("plane sweep: min_prior_confidence ", min_prior_confidence, " (0 to 1)");
  if (!positive(step_px)) fail("plane sweep: step_px ", step_px);
  if (min_hypotheses < 3 || max_hypotheses > ps::kMaxHypotheses || min_hypotheses > max_hypotheses)
    fail("plane sweep: hypotheses ", min_hypotheses, " to ", max_hypotheses, " (3 <= min <= max <= ",
         ps::kMaxHypotheses, ")");
  if (!(min_texture >= 0) || !std::isfinite(min_texture)) fail("plane sweep: min_texture ", min_texture);
  if (!(max_cost > 0 && max_cost < 1)) fail("plane sweep: max_cost ", max_cost, " (between 0 and 1)");
  if (!(uniqueness_margin >= 0 && uniqueness_margin < 2)) fail("plane sweep: uniqueness_margin ", uniqueness_margin);
  if (!(exclusion_px >= 0) || !std::isfinite(exclusion_px)) fail("plane sweep: exclusion_px ", exclusion_px);
  if (!positive(max_rel_per_px)) fail("plane sweep: max_rel_per_px ", max_rel_per_px);
}

namespace {

std::vector<float> gray_floats(const Image8& img) {
  const Image8 g = to_gray(img);
  return std::vector<float>(g.vec().begin(), g.vec().end());
}

}  // namespace

PreparedSweep prepare_sweep(const PlaneSweepInput& in, const PlaneSweepConfig& cfg) {
  cfg.validate();
  in.camera.validate("plane sweep camera");
  if (in.camera.distorted()) fail("plane sweep: the camera must be undistorted (", in.camera.describe(), ")");
  const int w = in.camera.width, h = in.camera.height;
  auto check_image = [&](const Image8* img, const char* what, size_t i) {
    if (!img || img->empty()) fail("plane sweep: ", what, " ", i, " has no image");
    if (img->width() != w || img->height() != h || (img->channels() != 1 && img->channels() != 3))
      fail("plane sweep: ", what, " ", i, " is ", img->width(), "x", img->height(), "x", img->channels(),
           ", the camera ", w, "x", h, " (gray or RGB)");
  };
  check_image(in.reference.image, "reference", 0);
  if (in.neighbours.empty() || in.neighbours.size() > size_t(ps::kMaxNeighbours))
    fail("plane sweep: ", in.neighbours.size(), " neighbour views (1 to ", ps::kMaxNeighbours, ")");
  for (size_t i = 0; i < in.neighbours.size(); ++i) check_image(in.neighbours[i].image, "neighbour", i);
  for (const ImageF* prior : {in.prior_inv_depth, in.prior_confidence})
    if (prior && (prior->width() != w || prior->height() != h || prior->channels() != 1))
      fail("plane sweep: a prior image is ", prior->width(), "x", prior->height(), "x", prior->channels(),
           ", the camera ", w, "x", h, "x1");
  if (in.prior_confidence && !in.prior_inv_depth) fail("plane sweep: a prior confidence without a prior");

  PreparedSweep s;
  s.ref = gray_floats(*in.reference.image);
  for (const SweepView& v : in.neighbours) s.neighbours.push_back(gray_floats(*v.image));
  if (in.prior_inv_depth) {
    s.prior_inv = in.prior_inv_depth->vec();
    for (float& v : s.prior_inv)
      if (!std::isfinite(v) || v < 0) v = 0;  // unusable prior values mean "no prior" (wide sweep)
    s.prior_conf = in.prior_confidence ? in.prior_confidence->vec() : std::vector<float>(s.prior_inv.size(), 1.0f);
  }
  ps::Problem& p = s.problem;
  p.width = w, p.height = h;
  p.ref = s.ref.data();
  p.neighbours = int(in.neighbours.size());
  const Eigen::Matrix3d K = in.camera.K(), Kinv = K.inverse();
  for (int j = 0; j < p.neighbours; ++j) {
    const SE3 T_nr = in.neighbours[size_t(j)].T_wc.inverse() * in.reference.T_wc;
    const Eigen::Matrix3d H = K * T_nr.rotation() * Kinv;
    const Eigen::Vector3d e = K * T_nr.t;
    if (!H.allFinite() || !e.allFinite()) fail("plane sweep: neighbour ", j, " has a non-finite pose");
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) p.nb[j].H[r * 3 + c] = float(H(r, c));
      p.nb[j].e[r] = float(e(r));
    }
    p.nb[j].image = s.neighbours[size_t(j)].data();
  }
  p.radius = cfg.patch_radius;
  p.best_k = cfg.best_k;
  p.min_views = cfg.min_views;
  p.inv_near = float(1.0 / cfg.near), p.inv_far = float(1.0 / cfg.far);
  p.prior_range = float(cfg.prior_range);
  p.prior_abs_range = float(cfg.prior_abs_range);
  p.min_prior_confidence = float(cfg.min_prior_confidence);
  p.step_px = float(cfg.step_px);
  p.min_hypotheses = cfg.min_hypotheses, p.max_hypotheses = cfg.max_hypotheses;
  p.min_texture2 = float(cfg.min_texture * cfg.min_texture);
  p.max_cost = float(cfg.max_cost);
  p.uniqueness_margin = float(cfg.uniqueness_margin);
  p.exclusion_px = float(cfg.exclusion_px);
  p.max_rel_per_px = float(cfg.max_rel_per_px);
  return s;
}

void check_sweep_pixels(const PreparedSweep& s, const std::vector<SweepPixel>& pixels) {
  for (size_t i = 0; i < pixels.size(); ++i)
    if (pixels[i].x < 0 || pixels[i].y < 0 || pixels[i].x >= s.problem.width || pixels[i].y >= s.problem.height)
      fail("plane sweep: requested pixel ", i, " (", pixels[i].x, ", ", pixels[i].y, ") lies outside the ",
           s.problem.width, "x", s.problem.height, " image");
}

namespace {

ps::PixelResult at(const PreparedSweep& s, int x, int y, float* costs) {
  const size_t i = size_t(y) * size_t(s.problem.width) + size_t(x);
  const float prior = s.prior_inv.empty() ? 0.0f : s.prior_inv[i];
  const float conf = s.prior_conf.empty() ? 0.0f : s.prior_conf[i];
  return ps::sweep_pixel(s.problem, x, y, prior, conf, costs);
}

void require_cuda_build(const PlaneSweepConfig& cfg) {
#ifndef CHUNGS_WITH_CUDA
  if (cfg.cuda) fail("plane sweep: cuda asked for, but this build has no CUDA");
#else
  (void)cfg;
#endif
}

}  // namespace

PlaneSweepDepth plane_sweep_dense(const PlaneSweepInput& input, const PlaneSweepConfig& config) {
  require_cuda_build(config);
#ifdef CHUNGS_WITH_CUDA
  if (config.cuda) return cuda::plane_sweep_dense(input, config);
#endif
  const PreparedSweep s = prepare_sweep(input, config);
  const int w = s.problem.width, h = s.problem.height;
  PlaneSweepDepth out;
  out.depth = ImageF(w, h, 1, 0.0f);
  out.confidence = ImageF(w, h, 1, 0.0f);
#pragma omp parallel
  {
    std::vector<float> costs(ps::kMaxHypotheses);
#pragma omp for schedule(dynamic, 4)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const ps::PixelResult r = at(s, x, y, costs.data());
        out.depth(x, y) = r.depth, out.confidence(x, y) = r.confidence;
      }
  }
  for (float d : out.depth.vec()) out.valid += d > 0;
  return out;
}

std::vector<SweepSample> plane_sweep_at(const PlaneSweepInput& input, const std::vector<SweepPixel>& pixels,
                                        const PlaneSweepConfig& config) {
  require_cuda_build(config);
#ifdef CHUNGS_WITH_CUDA
  if (config.cuda) return cuda::plane_sweep_at(input, pixels, config);
#endif
  const PreparedSweep s = prepare_sweep(input, config);
  check_sweep_pixels(s, pixels);
  std::vector<SweepSample> out(pixels.size());
#pragma omp parallel
  {
    std::vector<float> costs(ps::kMaxHypotheses);
#pragma omp for schedule(dynamic, 64)
    for (size_t i = 0; i < pixels.size(); ++i) {
      const ps::PixelResult r = at(s, pixels[i].x, pixels[i].y, costs.data());
      out[i] = {r.depth, r.confidence};
    }
  }
  return out;
}

}  // namespace chungs
