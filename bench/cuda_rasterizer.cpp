// CUDA rasterizer benchmark on the shared workload (chungs/render/bench_scene.hpp): forward and
// forward + backward, median of --reps timed calls after --warmup calls, device-event timing.
// Loss = sum(image * fixed uniform weights), so the backward starts from dL/dRGB = weights.
// Also timed: the fused mapping loss (L1 + SSIM with gradient) on the rendered image.
// Usage: bench_cuda_rasterizer [--json FILE] [--ply-dir DIR] [--reps 30] [--warmup 5] [--cases a,b]
//   --ply-dir writes each selected case's Gaussians as a standard 3DGS PLY (large: 0.5 M -> 124 MB),
//   also without a GPU.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/render/bench_scene.hpp"
#include "chungs/render/gaussian_view.hpp"
#include "chungs/render/render_camera.hpp"
#ifdef CHUNGS_WITH_CUDA
#include "chungs/cuda/devices.hpp"
#include "chungs/optim/cuda/loss.hpp"
#include "chungs/render/cuda/device_buffer.hpp"
#include "chungs/render/cuda/rasterizer.hpp"
#endif

namespace {

using namespace chungs;

struct Case {
  std::string name;
  int width, height;
  double f;
  size_t n;
  double ref_fwd, ref_fwdbwd;  // original 3DGS rasterizer, H100 (from the issue)
};

const std::vector<Case> kCases = {
    {"kitti_0.5M", 1241, 376, 718, 500000, 1.33, 6.47},
    {"kitti_1.5M", 1241, 376, 718, 1500000, 1.94, 9.03},
    {"tum_0.5M", 640, 480, 525, 500000, 1.26, 4.87},
    {"tum_1.5M", 640, 480, 525, 1500000, 1.61, 7.29},
    {"replica_0.5M", 1200, 680, 600, 500000, 1.69, 9.68},
    {"replica_1.5M", 1200, 680, 600, 1500000, 2.33, 12.31},
};

// Standard 3DGS PLY: x y z nx ny nz f_dc_0..2 f_rest_0..44 opacity scale_0..2 rot_0..3 (opacity as a
// logit, log scales, f_rest channel-major: f_rest[c * 15 + k - 1] = SH coefficient k of channel c).
void write_ply(const std::string& path, const GaussianParams& p) {
  std::ofstream out(path, std::ios::binary);
  if (!out) fail("cannot open ", path, " for writing");
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << p.size() << "\n";
  for (const char* c : {"x", "y", "z", "nx", "ny", "nz"}) out << "property float " << c << "\n";
  for (int i = 0; i < 3; ++i) out << "property float f_dc_" << i << "\n";
  for (int i = 0; i < 45; ++i) out << "property float f_rest_" << i << "\n";
  out << "property float opacity\n";
  for (int i = 0; i < 3; ++i) out << "property float scale_" << i << "\n";
  for (int i = 0; i < 4; ++i) out << "property float rot_" << i << "\n";
  out << "end_header\n";
  std::vector<float> row(62);
  for (size_t i = 0; i < p.size(); ++i) {
    float* r = row.data();
    for (int k = 0; k < 3; ++k) r[k] = p.mean[3 * i + k], r[3 + k] = 0.f;
    const float* sh = p.sh.data() + size_t(kShFloats) * i;
    for (int c = 0; c < 3; ++c) r[6 + c] = sh[c];
    for (int c = 0; c < 3; ++c)
      for (int k = 1; k < kShCoeffs; ++k) r[9 + c * 15 + k - 1] = sh[3 * k + c];
    r[54] = p.opacity[i];
    for (int k = 0; k < 3; ++k) r[55 + k] = p.log_scale[3 * i + k];
    for (int k = 0; k < 4; ++k) r[58 + k] = p.rotation[4 * i + k];
    out.write(reinterpret_cast<const char*>(r), std::streamsize(row.size() * sizeof(float)));
  }
  if (!out) fail("write failed: ", path);
}

[[maybe_unused]] double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  std::string json_path, ply_dir, only;
  [[maybe_unused]] int reps = 30, warmup = 5;  // used only in CUDA builds
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_cuda_rasterizer: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--json")
      json_path = value();
    else if (a == "--ply-dir")
      ply_dir = value();
    else if (a == "--reps")
      reps = std::max(1, std::stoi(value()));
    else if (a == "--warmup")
      warmup = std::max(0, std::stoi(value()));
    else if (a == "--cases")
      only = value();
    else {
      std::fprintf(stderr, "bench_cuda_rasterizer: unknown argument %s\n", a.c_str());
      return 2;
    }
  }
  auto selected = [&](const Case& c) {
    return only.empty() || ("," + only + ",").find("," + c.name + ",") != std::string::npos;
  };
  // The workload as PLY files needs no GPU: other renderers can be timed on the same Gaussians.
  if (!ply_dir.empty()) {
    try {
      for (const Case& c : kCases) {
        if (!selected(c)) continue;
        const Camera camera(c.width, c.height, c.f, c.f, (c.width - 1) / 2.0, (c.height - 1) / 2.0);
        const std::string path = ply_dir + "/" + c.name + ".ply";
        write_ply(path, make_bench_gaussians(c.n, camera));
        std::printf("wrote %s\n", path.c_str());
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_cuda_rasterizer: %s\n", e.what());
      return 1;
    }
  }
#ifndef CHUNGS_WITH_CUDA
  std::printf("bench_cuda_rasterizer: built without CUDA\n");
  return 0;
#else
  try {
    std::string why;
    const auto devices = cuda::list_devices(&why);
    if (devices.empty()) {
      std::printf("bench_cuda_rasterizer: no CUDA device (%s)\n", why.c_str());
      return 0;
    }
    std::printf("device: %s (sm_%d%d, %d SMs)  median of %d after %d warm-ups\n", devices[0].name.c_str(),
                devices[0].major, devices[0].minor, devices[0].multiprocessors, reps, warmup);
    std::printf("%-13s %9s %9s %8s %8s %8s %8s | %6s %6s %6s %6s %6s | %7s\n", "case", "pairs", "fwd_ms",
                "fb_ms", "ref_fwd", "ref_fb", "speedup", "prep", "sort", "comp", "bcomp", "bproj", "loss_ms");
    std::string json = "{\n  \"device\": \"" + devices[0].name + "\",\n  \"reps\": " + std::to_string(reps) +
                       ",\n  \"warmup\": " + std::to_string(warmup) + ",\n  \"cases\": [\n";
    bool first = true;
    for (const Case& c : kCases) {
      if (!selected(c)) continue;
      const Camera camera(c.width, c.height, c.f, c.f, (c.width - 1) / 2.0, (c.height - 1) / 2.0);
      const GaussianParams p = make_bench_gaussians(c.n, camera);
      const Image<float> weights = make_bench_weights(c.width, c.height);
      cuda::DeviceArray<float> mean(p.mean), ls(p.log_scale), rot(p.rotation), op(p.opacity), sh(p.sh);
      cuda::DeviceArray<float> dw(weights.vec());
      std::vector<uint32_t> ids(c.n);
      for (size_t i = 0; i < c.n; ++i) ids[i] = uint32_t(i);
      cuda::DeviceArray<uint32_t> dids(ids);
      const GaussianArrays<float> g{mean.data(), ls.data(), rot.data(), op.data(), sh.data(), c.n};
      const auto cam = make_render_camera<float>(camera, SE3());
      cuda::CudaRasterizer r;
      cuda::EventTimer timer;
      std::vector<double> fwd, fb;
      for (int i = 0; i < warmup + reps; ++i) {
        timer.start();
        r.forward(g, dids.data(), c.n, cam);
        const double ms = timer.stop_ms();
        if (i >= warmup) fwd.push_back(ms);
      }
      for (int i = 0; i < warmup + reps; ++i) {
        timer.start();
        r.forward(g, dids.data(), c.n, cam);
        r.backward({dw.data(), nullptr, nullptr, nullptr});
        const double ms = timer.stop_ms();
        if (i >= warmup) fb.push_back(ms);
      }
      std::vector<double> loss_ms;
      {
        cuda::CudaMappingLoss loss;
        LossConfig lc;
        lc.lambda_depth = 0;
        const auto& out = r.forward(g, dids.data(), c.n, cam);
        for (int i = 0; i < warmup + reps; ++i) {
          timer.start();
          loss.evaluate(lc, out, dw.data(), nullptr, nullptr, true);
          const double ms = timer.stop_ms();
          if (i >= warmup) loss_ms.push_back(ms);
        }
      }
      // One more call with per-stage events (they synchronise, so not part of the medians).
      r.enable_timings(true);
      r.forward(g, dids.data(), c.n, cam);
      r.backward({dw.data(), nullptr, nullptr, nullptr});
      const auto& t = r.timings();
      const double mf = median(fwd), mfb = median(fb);
      const double ml = median(loss_ms);
      std::printf("%-13s %8.2fM %9.3f %8.3f %8.2f %8.2f %7.2fx | %6.3f %6.3f %6.3f %6.3f %6.3f | %7.3f\n",
                  c.name.c_str(), r.tile_entries() / 1e6, mf, mfb, c.ref_fwd, c.ref_fwdbwd,
                  c.ref_fwdbwd / mfb, t.preprocess, t.sort, t.composite, t.composite_backward,
                  t.project_backward, ml);
      std::fflush(stdout);
      char buf[1024];
      std::snprintf(buf, sizeof buf,
                    "%s    {\"case\": \"%s\", \"width\": %d, \"height\": %d, \"f\": %g, \"gaussians\": %zu, "
                    "\"tile_pairs\": %zu, \"forward_ms\": %.4f, \"forward_backward_ms\": %.4f, "
                    "\"forward_min_ms\": %.4f, \"forward_backward_min_ms\": %.4f, \"mapping_loss_ms\": %.4f, "
                    "\"reference_forward_ms\": %.2f, \"reference_forward_backward_ms\": %.2f, "
                    "\"stages_ms\": {\"preprocess\": %.4f, \"sort\": %.4f, \"composite\": %.4f, "
                    "\"composite_backward\": %.4f, \"project_backward\": %.4f}}",
                    first ? "" : ",\n", c.name.c_str(), c.width, c.height, c.f, c.n, r.tile_entries(), mf,
                    mfb, *std::min_element(fwd.begin(), fwd.end()), *std::min_element(fb.begin(), fb.end()),
                    ml, c.ref_fwd, c.ref_fwdbwd, t.preprocess, t.sort, t.composite, t.composite_backward,
                    t.project_backward);
      json += buf;
      first = false;
    }
    json += "\n  ]\n}\n";
    if (!json_path.empty()) {
      std::ofstream(json_path) << json;
      std::printf("wrote %s\n", json_path.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_cuda_rasterizer: %s\n", e.what());
    return 1;
  }
  return 0;
#endif
}
