#include <cuda_runtime.h>

#include <mutex>

#include "chungs/common/error.hpp"
#include "chungs/depth/cuda/plane_sweep_cuda.hpp"
#include "chungs/depth/plane_sweep_problem.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs::cuda {

namespace ps = plane_sweep;

namespace {

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) fail("plane sweep on the GPU: ", what, ": ", cudaGetErrorString(e));
}

// The scratch curve lives in each thread's local memory (kMaxHypotheses floats): the per-pixel
// work is hundreds of patch costs, so its traffic is small beside the image reads.
__global__ void sweep_kernel(ps::Problem p, const float* __restrict__ prior_inv, const float* __restrict__ prior_conf,
                             const int* __restrict__ xy, int count, float* __restrict__ depth,
                             float* __restrict__ conf) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  int x, y;
  if (xy) {
    x = xy[2 * i], y = xy[2 * i + 1];
  } else {
    x = i % p.width, y = i / p.width;
  }
  const size_t at = size_t(y) * size_t(p.width) + size_t(x);
  const float prior = prior_inv ? prior_inv[at] : 0.0f, pc = prior_conf ? prior_conf[at] : 0.0f;
  float costs[ps::kMaxHypotheses];
  const ps::PixelResult r = ps::sweep_pixel(p, x, y, prior, pc, costs);
  depth[i] = r.depth;
  conf[i] = r.confidence;
}

struct Workspace {
  std::mutex mutex;
  cudaStream_t stream = nullptr;
  DeviceBytes images, priors, pixels, out;
};

Workspace& workspace() {
  static Workspace* ws = new Workspace;  // never destroyed: the runtime may be gone before statics die
  return *ws;
}

// Uploads the prepared problem, runs the kernel over `count` pixels (all, row-major, when xy is
// null) and downloads depth and confidence.
void run(const PreparedSweep& s, const std::vector<int>* xy, size_t count, float* depth, float* conf) {
  if (count == 0) return;
  if (count > size_t(1) << 30) fail("plane sweep on the GPU: ", count, " pixels");
  Workspace& ws = workspace();
  std::lock_guard lock(ws.mutex);
  if (!ws.stream) check(cudaStreamCreateWithFlags(&ws.stream, cudaStreamNonBlocking), "creating a stream");
  const size_t px = s.ref.size();
  const size_t views = 1 + s.neighbours.size();
  ws.images.reserve(views * px * sizeof(float));
  auto* img = static_cast<float*>(ws.images.data());
  ps::Problem p = s.problem;
  check(cudaMemcpyAsync(img, s.ref.data(), px * sizeof(float), cudaMemcpyHostToDevice, ws.stream), "uploading");
  p.ref = img;
  for (size_t j = 0; j < s.neighbours.size(); ++j) {
    float* dst = img + (j + 1) * px;
    check(cudaMemcpyAsync(dst, s.neighbours[j].data(), px * sizeof(float), cudaMemcpyHostToDevice, ws.stream),
          "uploading");
    p.nb[j].image = dst;
  }
  const float *prior = nullptr, *pconf = nullptr;
  if (!s.prior_inv.empty()) {
    ws.priors.reserve(2 * px * sizeof(float));
    auto* pr = static_cast<float*>(ws.priors.data());
    check(cudaMemcpyAsync(pr, s.prior_inv.data(), px * sizeof(float), cudaMemcpyHostToDevice, ws.stream), "uploading");
    check(cudaMemcpyAsync(pr + px, s.prior_conf.data(), px * sizeof(float), cudaMemcpyHostToDevice, ws.stream),
          "uploading");
    prior = pr, pconf = pr + px;
  }
  const int* dxy = nullptr;
  if (xy) {
    ws.pixels.reserve(xy->size() * sizeof(int));
    check(cudaMemcpyAsync(ws.pixels.data(), xy->data(), xy->size() * sizeof(int), cudaMemcpyHostToDevice, ws.stream),
          "uploading the pixels");
    dxy = static_cast<const int*>(ws.pixels.data());
  }
  ws.out.reserve(2 * count * sizeof(float));
  auto* out = static_cast<float*>(ws.out.data());
  sweep_kernel<<<unsigned((count + 127) / 128), 128, 0, ws.stream>>>(p, prior, pconf, dxy, int(count), out,
                                                                     out + count);
  check(cudaGetLastError(), "sweeping");
  check(cudaMemcpyAsync(depth, out, count * sizeof(float), cudaMemcpyDeviceToHost, ws.stream), "downloading");
  check(cudaMemcpyAsync(conf, out + count, count * sizeof(float), cudaMemcpyDeviceToHost, ws.stream), "downloading");
  check(cudaStreamSynchronize(ws.stream), "sweeping");
}

}  // namespace

PlaneSweepDepth plane_sweep_dense(const PlaneSweepInput& input, const PlaneSweepConfig& config) {
  const PreparedSweep s = prepare_sweep(input, config);
  PlaneSweepDepth r;
  r.depth = ImageF(s.problem.width, s.problem.height, 1, 0.0f);
  r.confidence = ImageF(s.problem.width, s.problem.height, 1, 0.0f);
  run(s, nullptr, r.depth.pixels(), r.depth.data(), r.confidence.data());
  for (float d : r.depth.vec()) r.valid += d > 0;
  return r;
}

std::vector<SweepSample> plane_sweep_at(const PlaneSweepInput& input, const std::vector<SweepPixel>& pixels,
                                        const PlaneSweepConfig& config) {
  const PreparedSweep s = prepare_sweep(input, config);
  check_sweep_pixels(s, pixels);
  std::vector<int> xy;
  xy.reserve(2 * pixels.size());
  for (const SweepPixel& q : pixels) xy.push_back(q.x), xy.push_back(q.y);
  std::vector<float> depth(pixels.size()), conf(pixels.size());
  run(s, &xy, pixels.size(), depth.data(), conf.data());
  std::vector<SweepSample> out(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) out[i] = {depth[i], conf[i]};
  return out;
}

}  // namespace chungs::cuda
