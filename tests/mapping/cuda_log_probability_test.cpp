// The sampler's probability maps on the GPU against their CPU twins (log_probability,
// sampling_probability) on random images of odd sizes, and the backends' acceptance maps agree.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/cuda/devices.hpp"
#include "chungs/mapping/cuda/log_probability.hpp"
#include "chungs/mapping/log_probability.hpp"
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/mapping/sampler.hpp"

namespace chungs {
namespace {

// Smooth shading plus pixel noise of a random amplitude: the LoG response then covers the whole
// range, with some pixels clamped to 1 and many in between.
ImageF random_image(int w, int h, int c, std::mt19937& rng) {
  std::uniform_real_distribution<float> U(0, 1);
  const float fx = 0.05f + 0.3f * U(rng), fy = 0.05f + 0.3f * U(rng), noise = 0.2f + 0.8f * U(rng);
  ImageF img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k)
        img(x, y, k) = std::clamp(0.5f + 0.3f * std::sin(fx * x + fy * y + k) + noise * (U(rng) - 0.5f), 0.f, 1.f);
  return img;
}

ImageF gpu_log_probability(const ImageF& img) {
  cuda::DeviceArray<float> in(img.vec()), out(size_t(img.width()) * img.height());
  cuda::CudaLogProbability log;
  log.compute(in.data(), img.width(), img.height(), img.channels(), out.data());
  ImageF p(img.width(), img.height(), 1);
  out.download(p.vec());
  return p;
}

double max_abs_diff(const ImageF& a, const ImageF& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(double(a.data()[i]) - b.data()[i]));
  return m;
}

TEST(CudaLogProbability, MatchesCpuTwinOnOddSizes) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(11);
  const int sizes[][3] = {{37, 23, 3}, {101, 55, 1}, {64, 33, 4}, {5, 3, 3}, {3, 9, 2}, {2, 7, 3}, {129, 67, 3}};
  for (const auto& s : sizes) {
    const ImageF img = random_image(s[0], s[1], s[2], rng);
    const ImageF cpu = log_probability(img), gpu = gpu_log_probability(img);
    const double d = max_abs_diff(cpu, gpu);
    EXPECT_LE(d, 1e-5) << s[0] << "x" << s[1] << "x" << s[2];
    std::printf("LoG parity %dx%dx%d: max |gpu - cpu| = %.3g\n", s[0], s[1], s[2], d);
  }
}

TEST(CudaLogProbability, MapIsNotTrivialOnTheTestImages) {
  // Guards the parity test: a map of zeros or ones everywhere would match any twin.
  std::mt19937 rng(11);
  const ImageF p = log_probability(random_image(37, 23, 3, rng));
  size_t between = 0;
  for (float v : p.vec()) between += v > 0.01f && v < 0.99f;
  EXPECT_GT(between, p.size() / 4);
}

TEST(CudaLogProbability, AcceptanceMapMatchesCpuTwin) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> U(0, 1);
  SamplerConfig c;
  c.density = 2.0;
  c.empty_floor = 0.05;
  const int sizes[][2] = {{53, 31}, {200, 77}};
  for (const auto& s : sizes) {
    const int w = s[0], h = s[1];
    const ImageF img = random_image(w, h, 3, rng), render = random_image(w, h, 3, rng);
    ImageF alpha(w, h, 1);
    for (float& a : alpha.vec()) a = U(rng);
    cuda::DeviceArray<float> di(img.vec()), dr(render.vec()), da(alpha.vec()), out(size_t(w) * h);
    cuda::CudaLogProbability log;
    for (bool with_render : {true, false}) {
      log.sampling_probability(di.data(), 3, with_render ? dr.data() : nullptr, with_render ? da.data() : nullptr,
                               w, h, c.density, c.empty_floor, out.data());
      ImageF gpu(w, h, 1);
      out.download(gpu.vec());
      const ImageF cpu = sampling_probability(c, img, with_render ? &render : nullptr, with_render ? &alpha : nullptr);
      const double d = max_abs_diff(cpu, gpu);
      EXPECT_LE(d, 1e-5) << w << "x" << h << " render " << with_render;
      std::printf("acceptance parity %dx%d (render %d): max |gpu - cpu| = %.3g\n", w, h, int(with_render), d);
    }
  }
}

TEST(CudaLogProbability, BackendsGiveTheSameAcceptanceMap) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(3);
  RenderCamera<float> cam;
  cam.width = 61, cam.height = 45, cam.fx = cam.fy = 50, cam.cx = 30, cam.cy = 22;
  const ImageF img = random_image(cam.width, cam.height, 3, rng);
  SamplerConfig c;
  c.empty_floor = 0.1;
  const auto cpu = make_optim_backend("cpu", 16, 3, RasterConfig{});
  const auto gpu = make_optim_backend("cuda", 16, 3, RasterConfig{});
  const ImageF a = cpu->sampling_probability({}, cam, c, img), b = gpu->sampling_probability({}, cam, c, img);
  ASSERT_TRUE(a.same_size(b));
  EXPECT_LE(max_abs_diff(a, b), 1e-5);
  EXPECT_THROW(gpu->sampling_probability({}, cam, c, random_image(60, 45, 3, rng)), Error);
}

TEST(CudaLogProbability, KittiSizedFrameMatchesAndIsTimed) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(7);
  const int w = 1241, h = 376;
  const ImageF img = random_image(w, h, 3, rng), render = random_image(w, h, 3, rng);
  ImageF alpha(w, h, 1, 1.f);
  cuda::DeviceArray<float> di(img.vec()), dr(render.vec()), da(alpha.vec()), out(size_t(w) * h);
  cuda::CudaLogProbability log;
  log.compute(di.data(), w, h, 3, out.data());  // warm-up and scratch allocation
  ImageF gpu(w, h, 1);
  out.download(gpu.vec());
  const double d = max_abs_diff(log_probability(img), gpu);
  EXPECT_LE(d, 1e-5);
  const int reps = 50;
  cuda::EventTimer t;
  t.start();
  for (int i = 0; i < reps; ++i) log.compute(di.data(), w, h, 3, out.data());
  const double one_ms = t.stop_ms() / reps;
  SamplerConfig c;
  log.sampling_probability(di.data(), 3, dr.data(), da.data(), w, h, c.density, c.empty_floor, out.data());
  t.start();
  for (int i = 0; i < reps; ++i)
    log.sampling_probability(di.data(), 3, dr.data(), da.data(), w, h, c.density, c.empty_floor, out.data());
  const double map_ms = t.stop_ms() / reps;
  std::printf("1241x376: max |gpu - cpu| = %.3g, LoG map %.4f ms, acceptance map (2 LoG + penalty) %.4f ms\n", d,
              one_ms, map_ms);
  RecordProperty("log_ms", std::to_string(one_ms));
  RecordProperty("acceptance_ms", std::to_string(map_ms));
}

}  // namespace
}  // namespace chungs
#endif
