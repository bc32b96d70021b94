// Parity of the CUDA rasterizer with its CPU twin on random scenes: images to 1e-4 and gradients to
// 1e-3 relative error (norm over each array). Skipped where no CUDA device is present.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/render/cpu/rasterizer.hpp"
#include "chungs/render/cuda/rasterizer.hpp"
#include "cuda_test_support.hpp"
#include "random_scene.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

using test::DeviceScene;
using test::rel_error;

struct Renders {
  RenderOutput<float> gpu;
  RenderOutput<float> cpu;
};

// Renders the scene with both rasterizers over the same (shuffled, sparse) slot list.
void render_both(const test::RandomScene& scene, const RasterConfig& cfg, const std::vector<uint32_t>& ids,
                 cuda::CudaRasterizer& gpu, CpuRasterizer<float>& cpu, Renders& r) {
  const auto g = scene.g.cast<float>();
  const DeviceScene dg(g);
  const cuda::DeviceArray<uint32_t> dids(ids);
  const auto cam = make_render_camera<float>(scene.camera, scene.pose);
  gpu.set_config(cfg);
  cpu.set_config(cfg);
  gpu.forward(dg.view(), dids.data(), ids.size(), cam);
  gpu.download(r.gpu);
  r.cpu = cpu.forward(g.view(), ids, cam);
}

void expect_images_match(const Renders& r, double tol) {
  const double e[5] = {
      rel_error(r.gpu.rgb.vec(), r.cpu.rgb.vec()), rel_error(r.gpu.depth.vec(), r.cpu.depth.vec()),
      rel_error(r.gpu.inv_depth.vec(), r.cpu.inv_depth.vec()),
      rel_error(r.gpu.alpha.vec(), r.cpu.alpha.vec()), rel_error(r.gpu.radius, r.cpu.radius)};
  std::printf("relative error rgb %.2e depth %.2e inv_depth %.2e alpha %.2e radius %.2e\n", e[0], e[1], e[2],
              e[3], e[4]);
  for (double v : e) EXPECT_LT(v, tol);
  EXPECT_EQ(r.gpu.visible, r.cpu.visible);
  // The comparison means something only if the scene covers the image.
  size_t covered = 0;
  for (float a : r.cpu.alpha.vec()) covered += a > 0.5f;
  EXPECT_GT(covered, r.cpu.alpha.vec().size() / 4);
  size_t same = 0;
  const auto& a = r.gpu.top_id.vec();
  const auto& b = r.cpu.top_id.vec();
  for (size_t i = 0; i < a.size(); ++i) same += a[i] == b[i];
  EXPECT_GE(double(same), 0.995 * double(a.size())) << "top_id differs at " << a.size() - same << " pixels";
}

std::vector<uint32_t> sparse_ids(size_t n, size_t capacity, unsigned seed) {
  std::vector<uint32_t> all(capacity);
  for (size_t i = 0; i < capacity; ++i) all[i] = uint32_t(i);
  std::mt19937 rng(seed);
  std::shuffle(all.begin(), all.end(), rng);
  all.resize(n);
  return all;
}

TEST(CudaRasterizer, ForwardMatchesCpuTwinOnRandomScenes) {
  CHUNGS_REQUIRE_GPU();
  cuda::CudaRasterizer gpu;
  CpuRasterizer<float> cpu;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    // Small scenes, and a crowded one whose tiles hold several 256-splat batches.
    const int n = seed <= 3 ? 300 : 3000;
    const auto scene = test::make_random_scene(seed, n, seed <= 3 ? 53 : 97, seed <= 3 ? 41 : 70);
    RasterConfig cfg;
    if (seed == 2) cfg.background = {0.2, 0.5, 0.9};
    if (seed == 3) cfg.sh_degree = 1;
    if (seed == 5) cfg = smooth_raster_config();
    Renders r;
    render_both(scene, cfg, sparse_ids(size_t(n) * 4 / 5, size_t(n), seed), gpu, cpu, r);
    expect_images_match(r, 1e-4);
  }
}

TEST(CudaRasterizer, EmptyListRendersBackground) {
  CHUNGS_REQUIRE_GPU();
  const auto scene = test::make_random_scene(9, 10);
  RasterConfig cfg;
  cfg.background = {0.25, 0.5, 0.75};
  cuda::CudaRasterizer gpu(cfg);
  const DeviceScene dg(scene.g.cast<float>());
  const auto cam = make_render_camera<float>(scene.camera, scene.pose);
  gpu.forward(dg.view(), nullptr, 0, cam);
  RenderOutput<float> out;
  gpu.download(out);
  for (int y = 0; y < out.rgb.height(); ++y)
    for (int x = 0; x < out.rgb.width(); ++x) {
      ASSERT_EQ(out.rgb(x, y, 1), 0.5f);
      ASSERT_EQ(out.alpha(x, y), 0.f);
      ASSERT_EQ(out.top_id(x, y), kNoGaussian);
    }
}

TEST(CudaRasterizer, IndexOutOfRangeThrowsNamingIt) {
  CHUNGS_REQUIRE_GPU();
  const auto scene = test::make_random_scene(4, 20);
  const DeviceScene dg(scene.g.cast<float>());
  std::vector<uint32_t> ids = test::iota_ids(20);
  ids[7] = 20;
  const cuda::DeviceArray<uint32_t> dids(ids);
  cuda::CudaRasterizer gpu;
  const auto cam = make_render_camera<float>(scene.camera, scene.pose);
  try {
    gpu.forward(dg.view(), dids.data(), ids.size(), cam);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("index 7"), std::string::npos) << e.what();
  }
}

// 70,000 copies of one splat that covers every tile of a 4096x4096 view need 70,000 x 65,536 tile entries,
// more than the 32-bit entry lists hold: refused by name before any list is sized, never wrapped around.
TEST(CudaRasterizer, MoreTileEntriesThanTheListsHoldAreRefused) {
  CHUNGS_REQUIRE_GPU();
  auto scene = test::make_random_scene(5, 1, 4096, 4096);
  const Eigen::Vector3d pw = scene.pose * Eigen::Vector3d(0, 0, 2);
  for (int k = 0; k < 3; ++k) scene.g.mean[k] = pw[k], scene.g.log_scale[k] = std::log(1000.0);
  scene.g.opacity[0] = 8;
  const DeviceScene dg(scene.g.cast<float>());
  const std::vector<uint32_t> ids(70000, 0u);
  const cuda::DeviceArray<uint32_t> dids(ids);
  cuda::CudaRasterizer gpu;
  const auto cam = make_render_camera<float>(scene.camera, scene.pose);
  try {
    gpu.forward(dg.view(), dids.data(), ids.size(), cam);
    FAIL() << "no error; " << gpu.tile_entries() << " entries";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("4587520000 tiles of 4096x4096"), std::string::npos) << e.what();
  }
  // The same rasterizer still renders a view that fits.
  const std::vector<uint32_t> few(3, 0u);
  const cuda::DeviceArray<uint32_t> dfew(few);
  gpu.forward(dg.view(), dfew.data(), few.size(), cam);
  EXPECT_EQ(gpu.tile_entries(), 3u * 65536u);
}

// Random dL/d(outputs) for all four images.
RenderGrads<double> random_grads(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> N(0, 1);
  RenderGrads<double> g{Image<double>(w, h, 3), Image<double>(w, h, 1), Image<double>(w, h, 1),
                        Image<double>(w, h, 1)};
  for (auto* img : {&g.rgb, &g.depth, &g.inv_depth, &g.alpha})
    for (double& v : img->vec()) v = N(rng);
  for (double& v : g.depth.vec()) v *= 0.1;
  return g;
}

std::vector<float> to_float(const std::vector<double>& v) { return std::vector<float>(v.begin(), v.end()); }

// The largest difference of any pixel's colour or alpha.
double largest_difference(const RenderOutput<float>& got, const RenderOutput<double>& want) {
  double worst = 0;
  for (size_t i = 0; i < want.rgb.vec().size(); ++i)
    worst = std::max(worst, std::abs(double(got.rgb.vec()[i]) - want.rgb.vec()[i]));
  for (size_t i = 0; i < want.alpha.vec().size(); ++i)
    worst = std::max(worst, std::abs(double(got.alpha.vec()[i]) - want.alpha.vec()[i]));
  return worst;
}

// The GPU's gradients for loss gradients dl of its last forward.
GaussianGrads<float> gpu_backward(cuda::CudaRasterizer& gpu, const RenderGrads<double>& dl) {
  const cuda::DeviceArray<float> drgb(to_float(dl.rgb.vec())), ddepth(to_float(dl.depth.vec())),
      dinv(to_float(dl.inv_depth.vec())), dalpha(to_float(dl.alpha.vec()));
  gpu.backward({drgb.data(), ddepth.data(), dinv.data(), dalpha.data()});
  GaussianGrads<float> got;
  gpu.download(got);
  return got;
}

// Each gradient array within 1e-3 of the float64 reference (relative, norm over the array).
void expect_grads_match(const GaussianGrads<float>& got, const GaussianGrads<double>& ref) {
  const double e[5] = {rel_error(got.mean, ref.mean), rel_error(got.log_scale, ref.log_scale),
                       rel_error(got.rotation, ref.rotation), rel_error(got.opacity, ref.opacity),
                       rel_error(got.sh, ref.sh)};
  std::printf("relative error d/dmean %.2e d/dlog_scale %.2e d/drotation %.2e d/dopacity %.2e d/dsh %.2e\n", e[0],
              e[1], e[2], e[3], e[4]);
  for (double v : e) EXPECT_LT(v, 1e-3);
}

// The float64 CPU twin's render of a scene's slots and its gradients for dl, and the GPU's forward of the
// same slots (their device copies kept here for its backward).
struct TwinRun {
  RenderOutput<double> want;
  GaussianGrads<double> ref;
  DeviceScene dg;
  cuda::DeviceArray<uint32_t> dids;
  TwinRun(cuda::CudaRasterizer& gpu, const test::RandomScene& scene, const RasterConfig& cfg,
          const std::vector<uint32_t>& ids, const RenderGrads<double>& dl)
      : dg(scene.g.cast<float>()), dids(ids) {
    CpuRasterizer<double> cpu(cfg);
    want = cpu.forward(scene.g.view(), ids, make_render_camera<double>(scene.camera, scene.pose));
    cpu.backward(dl, ref);
    gpu.set_config(cfg);
    gpu.forward(dg.view(), dids.data(), ids.size(), make_render_camera<float>(scene.camera, scene.pose));
  }
};

TEST(CudaRasterizer, GradientsMatchFloat64CpuTwin) {
  CHUNGS_REQUIRE_GPU();
  cuda::CudaRasterizer gpu;
  for (unsigned seed = 11; seed <= 14; ++seed) {
    SCOPED_TRACE(seed);
    const int n = seed % 2 ? 250 : 1500;
    const int w = seed % 2 ? 45 : 81, h = seed % 2 ? 38 : 64;
    const auto scene = test::make_random_scene(seed, n, w, h);
    RasterConfig cfg = seed <= 12 ? smooth_raster_config() : RasterConfig{};
    if (seed == 14) cfg.background = {0.3, 0.1, 0.6};
    const auto dl = random_grads(w, h, seed);
    const TwinRun twins(gpu, scene, cfg, sparse_ids(size_t(n) * 3 / 4, size_t(n), seed), dl);
    expect_grads_match(gpu_backward(gpu, dl), twins.ref);
  }
}

// The composite kernels walk, per warp, only the splats whose box reaches the warp's pixels. A splat
// wrongly skipped changes a few pixels and its own gradient, which a norm over the whole image can
// hide: here every pixel and every Gaussian is compared on a crowded scene of small splats (1.5-4.5 px)
// spread over several tiles and 256-splat batches, with splats centred off the image as well.
TEST(CudaRasterizer, SmallSplatsMatchTheCpuTwinAtEveryPixelAndGaussian) {
  CHUNGS_REQUIRE_GPU();
  const int w = 133, h = 71, n = 9000;
  const auto scene = test::make_random_scene(31, n, w, h);
  const auto ids = sparse_ids(size_t(n) * 9 / 10, size_t(n), 31);
  const auto dl = random_grads(w, h, 31);
  cuda::CudaRasterizer gpu;
  const TwinRun twins(gpu, scene, RasterConfig{}, ids, dl);
  const RenderOutput<double>& want = twins.want;
  const GaussianGrads<double>& ref = twins.ref;
  RenderOutput<float> got;
  gpu.download(got);
  EXPECT_LT(largest_difference(got, want), 2e-3) << "largest difference of a pixel's colour or alpha";

  const GaussianGrads<float> grads = gpu_backward(gpu, dl);
  // Per Gaussian: its opacity and colour (degree 0) gradients within 1 % of the largest of their kind.
  const auto each = [&](const std::vector<float>& a, const std::vector<double>& b, size_t stride,
                        size_t count, const char* what) {
    double top = 0;
    for (double v : b) top = std::max(top, std::abs(v));
    ASSERT_GT(top, 0) << what;
    size_t off = 0;
    for (size_t i = 0; i < a.size() / stride; ++i)
      for (size_t k = 0; k < count; ++k)
        off += std::abs(double(a[i * stride + k]) - b[i * stride + k]) > 0.01 * top;
    EXPECT_EQ(off, 0u) << what << ": Gaussians off by more than 1 % of the largest gradient";
  };
  each(grads.opacity, ref.opacity, 1, 1, "d/dopacity");
  each(grads.sh, ref.sh, kShFloats, 3, "d/dsh (degree 0)");
  each(grads.mean, ref.mean, 3, 3, "d/dmean");
}

// Crowded tiles composited in segments by several blocks (RasterConfig::segment_entries): the images and
// gradients are those of one block a tile, against the float64 CPU twin, with the transmittance stop
// falling inside later segments (the default config) and without it (the smooth one), and with segments
// short enough that most tiles are cut into many.
TEST(CudaRasterizer, CrowdedTilesInSegmentsMatchTheCpuTwin) {
  CHUNGS_REQUIRE_GPU();
  cuda::CudaRasterizer gpu;
  for (unsigned seed = 41; seed <= 44; ++seed) {
    SCOPED_TRACE(seed);
    const int n = 3000, w = 97, h = 70;
    const auto scene = test::make_random_scene(seed, n, w, h);
    RasterConfig cfg = seed == 42 ? smooth_raster_config() : RasterConfig{};
    cfg.segment_entries = seed == 43 ? 300 : 32;
    if (seed == 44) cfg.background = {0.3, 0.1, 0.6};
    const auto dl = random_grads(w, h, seed);
    const TwinRun twins(gpu, scene, cfg, sparse_ids(size_t(n) * 4 / 5, size_t(n), seed), dl);
    const RenderOutput<double>& want = twins.want;
    const size_t tiles = size_t((w + 15) / 16) * size_t((h + 15) / 16);
    EXPECT_GT(gpu.split_items(), seed == 43 ? size_t(0) : 2 * tiles)
        << "the tiles were not cut into segments";
    RenderOutput<float> got;
    gpu.download(got);
    EXPECT_LT(largest_difference(got, want), 2e-3) << "largest difference of a pixel's colour or alpha";
    EXPECT_LT(rel_error(got.depth.vec(), want.depth.vec()), 1e-4);
    size_t same = 0;
    for (size_t i = 0; i < got.top_id.vec().size(); ++i) same += got.top_id.vec()[i] == want.top_id.vec()[i];
    EXPECT_GE(double(same), 0.995 * double(got.top_id.vec().size()));

    expect_grads_match(gpu_backward(gpu, dl), twins.ref);
  }
}

TEST(CudaRasterizer, MissingGradientImagesCountAsZero) {
  CHUNGS_REQUIRE_GPU();
  const int w = 40, h = 33;
  const auto scene = test::make_random_scene(21, 200, w, h);
  const auto g = scene.g.cast<float>();
  const auto ids = test::iota_ids(200);
  const auto cam = make_render_camera<float>(scene.camera, scene.pose);
  CpuRasterizer<float> cpu;
  cpu.forward(g.view(), ids, cam);
  RenderGrads<float> dl;
  dl.rgb = Image<float>(w, h, 3);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0, 1);
  for (float& v : dl.rgb.vec()) v = U(rng);
  GaussianGrads<float> ref, got;
  cpu.backward(dl, ref);
  cuda::CudaRasterizer gpu;
  const DeviceScene dg(g);
  const cuda::DeviceArray<uint32_t> dids(ids);
  gpu.forward(dg.view(), dids.data(), ids.size(), cam);
  const cuda::DeviceArray<float> drgb(dl.rgb.vec());
  gpu.backward({drgb.data(), nullptr, nullptr, nullptr});
  gpu.download(got);
  EXPECT_LT(rel_error(got.mean, ref.mean), 1e-3);
  EXPECT_LT(rel_error(got.sh, ref.sh), 1e-3);
  EXPECT_LT(rel_error(got.opacity, ref.opacity), 1e-3);
}

}  // namespace
}  // namespace chungs
#endif
