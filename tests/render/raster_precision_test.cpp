// The float32 instantiation agrees with the float64 one on the same scene, forward and backward.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "chungs/render/cpu/rasterizer.hpp"
#include "random_scene.hpp"

namespace chungs {
namespace {

template <typename A, typename B>
double max_abs_diff(const std::vector<A>& a, const std::vector<B>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(double(a[i]) - double(b[i])));
  return m;
}

template <typename A>
double max_abs(const std::vector<A>& a) {
  double m = 0;
  for (A v : a) m = std::max(m, std::abs(double(v)));
  return m;
}

TEST(RasterPrecision, Float32AgreesWithFloat64) {
  for (unsigned seed : {21u, 22u}) {
    const test::RandomScene s = test::make_random_scene(seed, 40, 70, 50, 2.0);
    const test::SceneArrays<float> gf = s.g.cast<float>();
    const auto ids = test::iota_ids(s.g.size());
    RasterConfig cfg;
    cfg.background = {0.3, 0.3, 0.3};
    CpuRasterizer<double> rd(cfg);
    CpuRasterizer<float> rf(cfg);
    const auto& od = rd.forward(s.g.view(), ids, make_render_camera<double>(s.camera, s.pose));
    const auto& of = rf.forward(gf.view(), ids, make_render_camera<float>(s.camera, s.pose));
    // Images are within float rounding except where float rounding moves a pixel across the
    // 1/255 alpha cut (a jump of at most ~1/255 in a handful of pixels).
    size_t far = 0;
    for (size_t i = 0; i < od.rgb.size(); ++i) far += std::abs(od.rgb.data()[i] - of.rgb.data()[i]) > 1e-4;
    EXPECT_LE(far, od.rgb.size() / 1000) << "seed " << seed;
    EXPECT_LT(max_abs_diff(od.alpha.vec(), of.alpha.vec()), 5e-3);

    // Gradients: random weights on every output; compare per parameter group relative to its scale.
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(-1, 1);
    RenderGrads<double> wd{Image<double>(70, 50, 3), Image<double>(70, 50), Image<double>(70, 50),
                           Image<double>(70, 50)};
    RenderGrads<float> wf{Image<float>(70, 50, 3), Image<float>(70, 50), Image<float>(70, 50),
                          Image<float>(70, 50)};
    for (auto [d, f] : {std::pair{&wd.rgb, &wf.rgb},
                        {&wd.depth, &wf.depth},
                        {&wd.inv_depth, &wf.inv_depth},
                        {&wd.alpha, &wf.alpha}})
      for (size_t i = 0; i < d->size(); ++i) f->data()[i] = float(d->data()[i] = U(rng));
    // The smooth configuration keeps both precisions on the same side of every cut-off.
    rd.set_config(smooth_raster_config());
    rf.set_config(smooth_raster_config());
    rd.forward(s.g.view(), ids, make_render_camera<double>(s.camera, s.pose));
    rf.forward(gf.view(), ids, make_render_camera<float>(s.camera, s.pose));
    GaussianGrads<double> gd;
    GaussianGrads<float> gfl;
    rd.backward(wd, gd);
    rf.backward(wf, gfl);
    EXPECT_LT(max_abs_diff(gd.mean, gfl.mean), 1e-4 * max_abs(gd.mean));
    EXPECT_LT(max_abs_diff(gd.log_scale, gfl.log_scale), 1e-4 * max_abs(gd.log_scale));
    EXPECT_LT(max_abs_diff(gd.rotation, gfl.rotation), 1e-4 * max_abs(gd.rotation));
    EXPECT_LT(max_abs_diff(gd.opacity, gfl.opacity), 1e-4 * max_abs(gd.opacity));
    EXPECT_LT(max_abs_diff(gd.sh, gfl.sh), 1e-4 * max_abs(gd.sh));
    std::printf(
        "seed %u float32 vs float64, max difference / max |grad|: mean %.1e scale %.1e rot %.1e "
        "opacity %.1e sh %.1e\n",
        seed, max_abs_diff(gd.mean, gfl.mean) / max_abs(gd.mean),
        max_abs_diff(gd.log_scale, gfl.log_scale) / max_abs(gd.log_scale),
        max_abs_diff(gd.rotation, gfl.rotation) / max_abs(gd.rotation),
        max_abs_diff(gd.opacity, gfl.opacity) / max_abs(gd.opacity),
        max_abs_diff(gd.sh, gfl.sh) / max_abs(gd.sh));
  }
}

}  // namespace
}  // namespace chungs
