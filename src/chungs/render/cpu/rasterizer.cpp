#include "chungs/render/cpu/rasterizer.hpp"

#include <chrono>

#include "chungs/common/error.hpp"
#include "chungs/render/cpu/composite.hpp"
#include "chungs/render/cpu/projection.hpp"

namespace chungs {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

template <typename T>
void check_grad_image(const Image<T>& img, int w, int h, int channels, const char* name) {
  if (img.empty()) return;
  if (img.width() != w || img.height() != h || img.channels() != channels)
    fail("rasterizer backward: gradient of ", name, " is ", img.width(), "x", img.height(), "x",
         img.channels(), ", the render is ", w, "x", h, "x", channels);
}
}  // namespace

template <typename T>
CpuRasterizer<T>::CpuRasterizer(const RasterConfig& config) {
  set_config(config);
}

template <typename T>
void CpuRasterizer<T>::set_config(const RasterConfig& config) {
  config.validate();
  config_ = config;
  have_forward_ = false;
}

template <typename T>
const RenderOutput<T>& CpuRasterizer<T>::forward(const GaussianArrays<T>& g, std::span<const uint32_t> ids,
                                                 const RenderCamera<T>& camera) {
  if (camera.width <= 0 || camera.height <= 0)
    fail("rasterizer: image size must be positive, got ", camera.width, "x", camera.height);
  if (!(camera.fx > 0 && camera.fy > 0)) fail("rasterizer: focal lengths must be positive");
  check_indices(g, ids.data(), ids.size(), "rasterizer");
  g_ = g;
  ids_.assign(ids.begin(), ids.end());
  camera_ = camera;
  const int W = camera.width, H = camera.height;
  if (out_.rgb.width() != W || out_.rgb.height() != H || out_.rgb.empty()) {
    out_.rgb = Image<T>(W, H, 3);
    out_.depth = Image<T>(W, H, 1);
    out_.inv_depth = Image<T>(W, H, 1);
    out_.alpha = Image<T>(W, H, 1);
    out_.top_id = Image<uint32_t>(W, H, 1);
  }

  auto t0 = Clock::now();
  frame_config_ = config_;
  frame_config_.low_pass = config_.low_pass_for(W, H);  // the backward uses it too
  cpu::project_splats(g, ids_.data(), ids_.size(), camera, frame_config_, splats_);
  timings_.project = ms_since(t0);

  t0 = Clock::now();
  cpu::bin_splats(splats_, W, H, bins_);
  timings_.bin = ms_since(t0);

  t0 = Clock::now();
  cpu::composite_forward(splats_, bins_, ids_.data(), frame_config_, out_, last_);
  const size_t n = ids_.size();
  out_.visible.resize(n);
  out_.radius.resize(n);
  for (size_t j = 0; j < n; ++j) {
    out_.visible[j] = splats_[j].visible() ? 1 : 0;
    out_.radius[j] = splats_[j].visible() ? splats_[j].radius : T(0);
  }
  timings_.composite = ms_since(t0);
  have_forward_ = true;
  return out_;
}

template <typename T>
void CpuRasterizer<T>::backward(const RenderGrads<T>& dloss, GaussianGrads<T>& grads) {
  if (!have_forward_) fail("rasterizer backward: no forward render to differentiate");
  const int W = camera_.width, H = camera_.height;
  check_grad_image(dloss.rgb, W, H, 3, "rgb");
  check_grad_image(dloss.depth, W, H, 1, "depth");
  check_grad_image(dloss.inv_depth, W, H, 1, "inverse depth");
  check_grad_image(dloss.alpha, W, H, 1, "alpha");

  auto t0 = Clock::now();
  cpu::composite_backward(splats_, bins_, frame_config_, out_, last_, dloss, thread_buffers_, splat_grads_);
  timings_.composite_backward = ms_since(t0);

  t0 = Clock::now();
  cpu::backward_splats(g_, ids_.data(), ids_.size(), camera_, frame_config_, splats_, splat_grads_.data(), grads);
  timings_.project_backward = ms_since(t0);
}

template class CpuRasterizer<float>;
template class CpuRasterizer<double>;

}  // namespace chungs
