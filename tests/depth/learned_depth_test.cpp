// The optional learned depth (issue 25): the median/MAD fit against a float64 reference on random
// inputs with outliers, the aligned prior, and the model loader and predict() on tiny ONNX models
// that make_tiny_depth_model.py writes (skipped, saying why, without python3-onnx or ONNX Runtime), and
// the model as the plane sweep's prior source.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <thread>

#include "chungs/depth/learned_depth.hpp"
#include "chungs/depth/learned_prior.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {

// ---- the fit, against a float64 reference written the plain way (full sorts) ----

double ref_median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
double ref_quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[size_t(q * (v.size() - 1))];
}
double ref_mad(const std::vector<double>& v) {
  const double m = ref_median(v);
  std::vector<double> d;
  for (double x : v) d.push_back(std::abs(x - m));
  return ref_median(d);
}
struct RefFit {
  double scale = 0, shift = 0;
  size_t inliers = 0;
};
RefFit ref_fit(const std::vector<double>& p, const std::vector<double>& depth, double k) {
  std::vector<double> t;
  for (double d : depth) t.push_back(1.0 / d);
  auto line = [](const std::vector<double>& pp, const std::vector<double>& tt) {
    RefFit f;
    f.scale = ref_mad(tt) / ref_mad(pp);
    f.shift = ref_median(tt) - f.scale * ref_median(pp);
    f.inliers = pp.size();
    return f;
  };
  RefFit first = line(p, t);
  std::vector<double> r;
  for (size_t i = 0; i < p.size(); ++i) r.push_back(first.scale * p[i] + first.shift - t[i]);
  const double mr = ref_median(r), sr = std::max(ref_mad(r), 1e-9 * ref_median(t));
  std::vector<double> pi, ti;
  for (size_t i = 0; i < p.size(); ++i)
    if (std::abs(r[i] - mr) <= k * sr) pi.push_back(p[i]), ti.push_back(t[i]);
  return line(pi, ti);
}

struct Problem {
  std::vector<double> p, depth;
  double scale = 0, shift = 0;
  std::vector<bool> outlier;
};
// Inverse depth = scale * p + shift (+0.3 % noise) for most samples; a share of them pushed far off.
Problem random_problem(std::mt19937& rng, size_t n, double outlier_share) {
  std::uniform_real_distribution<double> u(0, 1);
  Problem pr;
  pr.scale = 0.02 + 2 * u(rng);
  const double pmin = -3 + u(rng);
  pr.shift = -pr.scale * pmin + 0.01 + u(rng);
  std::normal_distribution<double> noise(0, 0.003);
  for (size_t i = 0; i < n; ++i) {
    const double p = pmin + 6 * u(rng);
    double inv = (pr.scale * p + pr.shift) * (1 + noise(rng));
    const bool out = u(rng) < outlier_share;
    if (out) inv *= u(rng) < 0.5 ? 0.2 + 0.3 * u(rng) : 2 + 3 * u(rng);
    pr.p.push_back(p);
    pr.depth.push_back(1 / inv);
    pr.outlier.push_back(out);
  }
  return pr;
}

}  // namespace

TEST(InverseDepthFit, MatchesFloat64ReferenceOnRandomInputsWithOutliers) {
  std::mt19937 rng(25);
  for (int trial = 0; trial < 100; ++trial) {
    const size_t n = 20 + rng() % 400;
    const Problem pr = random_problem(rng, n, 0.3 * (trial % 6) / 5.0);  // 0 .. 30 % outliers
    const InverseDepthFit f = fit_inverse_depth(pr.p, pr.depth);
    ASSERT_TRUE(f.ok) << f.refused;
    const RefFit ref = ref_fit(pr.p, pr.depth, 5.0);
    EXPECT_NEAR(f.scale, ref.scale, 1e-12 * std::abs(ref.scale)) << "trial " << trial;
    EXPECT_NEAR(f.shift, ref.shift, 1e-12 * (std::abs(ref.shift) + std::abs(ref.scale))) << "trial " << trial;
    EXPECT_EQ(f.inliers, ref.inliers) << "trial " << trial;
    EXPECT_EQ(f.samples, n);
  }
}

// How close the paper's fit (one refit after dropping outliers) comes to the truth: the median over
// random problems, per outlier share. A MAD ratio is a noisy scale estimate with a tail: single
// problems with many outliers can be off by tens of per cent (bench/README.md has the spread).
TEST(InverseDepthFit, RecoversTheScaleUnderFewOutliers) {
  std::mt19937 rng(26);
  for (double share : {0.0, 0.05, 0.1, 0.2}) {
    std::vector<double> err, rel, kept;
    for (int trial = 0; trial < 200; ++trial) {
      const Problem pr = random_problem(rng, 20 + rng() % 400, share);
      const InverseDepthFit f = fit_inverse_depth(pr.p, pr.depth);
      ASSERT_TRUE(f.ok) << f.refused;
      err.push_back(std::abs(f.scale / pr.scale - 1));
      rel.push_back(f.median_rel_error);
      size_t clean = 0;
      for (bool o : pr.outlier) clean += !o;
      kept.push_back(double(f.inliers) / clean);
    }
    const double med_err = ref_median(err), med_rel = ref_median(rel), med_kept = ref_median(kept);
    std::printf("outliers %.0f %%: scale error median %.4f, p90 %.4f, max %.4f; inliers' median relative depth error "
                "%.4f; inliers / clean samples %.3f\n",
                100 * share, med_err, ref_quantile(err, 0.9), *std::max_element(err.begin(), err.end()), med_rel,
                med_kept);
    EXPECT_LT(med_err, share <= 0.1 ? 0.006 : 0.02) << share;
    EXPECT_LT(med_rel, 0.006) << share;
    EXPECT_GT(med_kept, 0.95) << share;
  }
}

TEST(InverseDepthFit, ExactDataGiveExactLine) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.1, 5);
  std::vector<double> p, d;
  for (int i = 0; i < 50; ++i) {
    p.push_back(u(rng));
    d.push_back(1 / (0.7 * p.back() + 0.05));
  }
  const InverseDepthFit f = fit_inverse_depth(p, d);
  ASSERT_TRUE(f.ok) << f.refused;
  EXPECT_NEAR(f.scale, 0.7, 1e-12);
  EXPECT_NEAR(f.shift, 0.05, 1e-12);
  EXPECT_EQ(f.inliers, 50u);
  EXPECT_LT(f.median_rel_error, 1e-12);
}

TEST(InverseDepthFit, RefusesTooFewOrDegenerateSamplesSayingWhy) {
  std::vector<double> p = {0.1, 0.5, 0.9, 1.3}, d = {4, 3, 2, 1};
  InverseDepthFit f = fit_inverse_depth(p, d);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.refused.find("4 usable samples (of 4), at least 5 needed"), std::string::npos) << f.refused;
  // Unusable pairs are not counted: a non-positive or non-finite depth, a non-finite prediction.
  p = {0.1, 0.5, 0.9, 1.3, 1.7, 2.1, 2.5};
  d = {4, 3, 2, 1, 0, -1, std::nan("")};
  f = fit_inverse_depth(p, d);
  EXPECT_FALSE(f.ok);
  EXPECT_EQ(f.samples, 4u);
  EXPECT_NE(f.refused.find("4 usable samples (of 7)"), std::string::npos) << f.refused;
  // A flat prediction gives no scale, nor do equal depths.
  f = fit_inverse_depth({0.3, 0.3, 0.3, 0.3, 0.3, 0.3}, {1, 2, 3, 4, 5, 6});
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.refused.find("prediction does not vary"), std::string::npos) << f.refused;
  f = fit_inverse_depth({0.1, 0.2, 0.3, 0.4, 0.5, 0.6}, {2, 2, 2, 2, 2, 2});
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.refused.find("sample depths do not vary"), std::string::npos) << f.refused;
  // A prediction that rises with depth (a depth model read as inverse depth).
  f = fit_inverse_depth({0.1, 0.2, 0.3, 0.4, 0.5, 0.6}, {1, 2, 3, 4, 5, 6});
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.refused.find("model's output depth"), std::string::npos) << f.refused;
  // Bad options are errors, not refusals.
  InverseDepthFitOptions o;
  o.outlier_mads = 0;
  EXPECT_THROW(fit_inverse_depth(p, d, o), Error);
  EXPECT_THROW(fit_inverse_depth({1, 2}, {1}), Error);
}

TEST(AlignInverseDepth, MetricDepthEverywhereAndConfidenceLowAtEdges) {
  std::mt19937 rng(3);
  // A relative prediction: a gentle ramp down the rows with a step (a near object) in the middle
  // columns. Tall enough that the ramp is smooth in units of the image's own spread.
  const int w = 64, h = 400;
  ImageF pred(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) pred(x, y) = 0.5f + 0.001f * y + (x >= 28 && x < 36 ? 1.5f : 0.f);
  const double s = 0.4, o = 0.02;
  std::uniform_real_distribution<float> ux(-10, w + 10), uy(-5, h + 5);
  std::vector<DepthSample> samples;
  for (int i = 0; i < 300; ++i) {
    DepthSample smp;
    smp.x = ux(rng), smp.y = uy(rng);
    const int xi = int(std::lround(smp.x)), yi = int(std::lround(smp.y));
    const bool inside = xi >= 0 && yi >= 0 && xi < w && yi < h;
    smp.depth = inside ? float(1 / (s * pred(xi, yi) + o)) : 1000.f;  // outside: must not count
    samples.push_back(smp);
  }
  const AlignedDepth a = align_inverse_depth(pred, samples);
  ASSERT_TRUE(a.fit.ok) << a.fit.refused;
  EXPECT_LT(a.fit.samples, samples.size());
  EXPECT_NEAR(a.fit.scale, s, 1e-5);
  EXPECT_NEAR(a.fit.shift, o, 1e-5);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double want = 1 / (s * pred(x, y) + o);
      ASSERT_NEAR(a.depth(x, y), want, 1e-4 * want) << x << "," << y;
      ASSERT_NEAR(a.prior.inv_depth(x, y), 1 / want, 1e-4 / want);
    }
  // The confidence against a float64 reference: exp(-|Sobel|^2 / 0.2) of (p - median) / MAD, borders
  // replicated.
  std::vector<double> all(pred.vec().begin(), pred.vec().end());
  const double med = ref_median(all), mad = ref_mad(all);
  auto n = [&](int x, int y) {
    return (double(pred(std::clamp(x, 0, w - 1), std::clamp(y, 0, h - 1))) - med) / mad;
  };
  const std::pair<int, int> pixels[] = {{10, 200}, {28, 200}, {35, 17}, {0, 0}, {63, 399}, {27, 100}};
  for (auto [x, y] : pixels) {
    const double gx = n(x + 1, y - 1) + 2 * n(x + 1, y) + n(x + 1, y + 1) - n(x - 1, y - 1) - 2 * n(x - 1, y) -
                      n(x - 1, y + 1);
    const double gy = n(x - 1, y + 1) + 2 * n(x, y + 1) + n(x + 1, y + 1) - n(x - 1, y - 1) - 2 * n(x, y - 1) -
                      n(x + 1, y - 1);
    EXPECT_NEAR(a.prior.confidence(x, y), std::exp(-(gx * gx + gy * gy) / 0.2), 1e-5) << x << "," << y;
  }
  // Smooth ramp: confident; at the step: not.
  EXPECT_GT(a.prior.confidence(10, 200), 0.9f);
  EXPECT_LT(a.prior.confidence(28, 200), 0.01f);
  EXPECT_LT(a.prior.confidence(35, 200), 0.01f);
  // max_depth drops what lies deeper.
  InverseDepthFitOptions lim;
  lim.max_depth = 1 / (s * 0.9 + o);
  const AlignedDepth b = align_inverse_depth(pred, samples, lim);
  ASSERT_TRUE(b.fit.ok);
  EXPECT_EQ(b.depth(10, 0), 0.f);  // pred 0.5: deeper than the limit
  EXPECT_EQ(b.prior.inv_depth(10, 0), 0.f);
  EXPECT_GT(b.depth(30, 0), 0.f);  // pred 2.0
}

TEST(AlignInverseDepth, TooFewSamplesInsideTheImageIsRefusedNotThrown) {
  ImageF pred(20, 10, 1, 1.f);
  std::vector<DepthSample> samples(8);
  for (size_t i = 0; i < samples.size(); ++i) samples[i] = {float(100 + i), 5.f, 2.f, 1.f};
  const AlignedDepth a = align_inverse_depth(pred, samples);
  EXPECT_FALSE(a.fit.ok);
  EXPECT_NE(a.fit.refused.find("0 usable samples"), std::string::npos) << a.fit.refused;
  EXPECT_NE(a.fit.refused.find("8 of 8 samples outside the 20x10 image"), std::string::npos) << a.fit.refused;
  EXPECT_TRUE(a.depth.empty());
  EXPECT_THROW(align_inverse_depth(ImageF(), samples), Error);
}

// ---- the model loader and predict() on generated models ----

namespace {

const fs::path kGenerator = fs::path(__FILE__).parent_path() / "make_tiny_depth_model.py";
// Debian's interpreter: python3-onnx installs for it (another python3 on PATH may lack onnx).
const char* kPython = "/usr/bin/python3";

std::string generator_missing() {
  if (!fs::exists(kPython)) return std::string(kPython) + " is not installed";
  if (std::system((std::string(kPython) + " -c 'import onnx' >/dev/null 2>&1").c_str()) != 0)
    return "python3-onnx is not installed (apt-get install python3-onnx; scripts/setup.sh does)";
  return "";
}

fs::path make_model(const test::TempDir& dir, const std::string& kind, const std::string& extra = "") {
  const fs::path out = dir / (kind + ".onnx");
  const std::string cmd = std::string(kPython) + " " + kGenerator.string() + " --out " + out.string() + " --kind " +
                          kind + " " + extra;
  if (std::system(cmd.c_str()) != 0) throw Error("generator failed: " + cmd);
  return out;
}

#define SKIP_WITHOUT_MODEL_TOOLS()                                                  \
  do {                                                                              \
    const std::string why = generator_missing();                                    \
    if (!why.empty()) GTEST_SKIP() << "no test models: " << why;                    \
    const DepthRuntimeProbe rt = probe_depth_runtime();                             \
    if (!rt.available) GTEST_SKIP() << "no runtime: " << rt.reason;                 \
  } while (0)

Image8 random_rgb(int w, int h, uint32_t seed) {
  std::mt19937 rng(seed);
  Image8 img(w, h, 3);
  for (auto& v : img.vec()) v = uint8_t(rng() % 256);
  return img;
}

// The tiny model's function (make_tiny_depth_model.py), in double, on the normalised planes.
double tiny_model(const ImageF& rgb, int x, int y, const double mean[3], const double std[3], const double wgt[3],
                  double bias) {
  double v = bias;
  for (int c = 0; c < 3; ++c) v += wgt[c] * ((double(rgb(x, y, c)) - mean[c]) / std[c]);
  return v;
}
const double kImageNetMean[3] = {0.485, 0.456, 0.406}, kImageNetStd[3] = {0.229, 0.224, 0.225};
const double kW[3] = {0.5, -0.25, 2.0}, kB = 0.1;

void expect_near_rel(double got, double want, const std::string& where) {
  EXPECT_NEAR(got, want, 2e-5 * (1 + std::abs(want))) << where;
}

}  // namespace

TEST(LearnedDepth, DynamicModelPredictsTheExactFunctionAtTheImageSize) {
  SKIP_WITHOUT_MODEL_TOOLS();
  test::TempDir dir;
  auto model = LearnedDepth::load(make_model(dir, "dynamic"), 1);
  EXPECT_NE(model->describe().find("images at their size"), std::string::npos) << model->describe();
  const Image8 img = random_rgb(37, 23, 1);
  const ImageF pred = model->predict(img);
  ASSERT_EQ(pred.width(), 37);
  ASSERT_EQ(pred.height(), 23);
  ASSERT_EQ(pred.channels(), 1);
  const ImageF rgb = to_float(img);
  for (int y = 0; y < 23; ++y)
    for (int x = 0; x < 37; ++x)
      expect_near_rel(pred(x, y), tiny_model(rgb, x, y, kImageNetMean, kImageNetStd, kW, kB), cat(x, ",", y));
  // A gray image goes in as three equal planes.
  Image8 gray(37, 23, 1);
  for (size_t i = 0; i < gray.size(); ++i) gray.data()[i] = uint8_t(i * 7);
  const ImageF pg = model->predict(gray), g3 = to_rgb(to_float(gray));
  for (int y = 0; y < 23; y += 5)
    for (int x = 0; x < 37; x += 3)
      expect_near_rel(pg(x, y), tiny_model(g3, x, y, kImageNetMean, kImageNetStd, kW, kB), cat("gray ", x, ",", y));
}

TEST(LearnedDepth, FixedModelResizesInAndOut) {
  SKIP_WITHOUT_MODEL_TOOLS();
  test::TempDir dir;
  const Image8 img = random_rgb(40, 30, 2);
  // The model's 16x12 input: the image resized (bilinear), run, the 16x12 output resized back.
  const ImageF small = resize_bilinear(to_float(img), 16, 12);
  ImageF want_small(16, 12, 1);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 16; ++x) want_small(x, y) = float(tiny_model(small, x, y, kImageNetMean, kImageNetStd, kW, kB));
  const ImageF want = resize_bilinear(want_small, 40, 30);
  for (const char* kind : {"good", "rank3"}) {
    auto model = LearnedDepth::load(make_model(dir, kind), 1);
    EXPECT_NE(model->describe().find("resized to 16x12"), std::string::npos) << model->describe();
    const ImageF pred = model->predict(img);
    ASSERT_EQ(pred.width(), 40);
    ASSERT_EQ(pred.height(), 30);
    for (int y = 0; y < 30; ++y)
      for (int x = 0; x < 40; ++x) expect_near_rel(pred(x, y), want(x, y), cat(kind, " ", x, ",", y));
  }
}

TEST(LearnedDepth, MetadataSetsNormalisationAndDepthOutput) {
  SKIP_WITHOUT_MODEL_TOOLS();
  test::TempDir dir;
  const Image8 img = random_rgb(16, 12, 3);
  const ImageF rgb = to_float(img);
  auto meta = LearnedDepth::load(make_model(dir, "meta", "--mean 0.5,0.25,0.75 --std 0.5,0.125,2"), 1);
  const double mean[3] = {0.5, 0.25, 0.75}, sd[3] = {0.5, 0.125, 2};
  ImageF pred = meta->predict(img);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 16; ++x) expect_near_rel(pred(x, y), tiny_model(rgb, x, y, mean, sd, kW, kB), cat(x, ",", y));
  // chungs.output = depth: predict() returns its inverse.
  auto depth = LearnedDepth::load(make_model(dir, "depth"), 1);
  EXPECT_NE(depth->describe().find(" depth, mean"), std::string::npos) << depth->describe();
  const double wd[3] = {0.5, 0.25, 0.125};
  pred = depth->predict(img);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 16; ++x)
      expect_near_rel(pred(x, y), 1 / tiny_model(rgb, x, y, kImageNetMean, kImageNetStd, wd, 3.0), cat(x, ",", y));
}

TEST(LearnedDepth, PredictFromSeveralThreadsAtOnceGivesTheSameMaps) {
  SKIP_WITHOUT_MODEL_TOOLS();
  test::TempDir dir;
  auto model = LearnedDepth::load(make_model(dir, "dynamic"), 1);
  const Image8 a = random_rgb(50, 30, 4), b = random_rgb(50, 30, 5);
  const ImageF ra = model->predict(a), rb = model->predict(b);
  std::vector<ImageF> got(4);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i) threads.emplace_back([&, i] { got[i] = model->predict(i % 2 ? b : a); });
  for (auto& t : threads) t.join();
  for (int i = 0; i < 4; ++i) EXPECT_EQ(got[i].vec(), (i % 2 ? rb : ra).vec()) << i;
}

namespace {

// What LearnedDepth::load says of a file, or "no error".
std::string error_of(const fs::path& p) {
  try {
    LearnedDepth::load(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(LearnedDepth, LoaderRefusesModelsOutsideTheContractNamingTheFile) {
  SKIP_WITHOUT_MODEL_TOOLS();
  test::TempDir dir;
  const fs::path text = dir / "notes.onnx";
  std::ofstream(text) << "this is not a protobuf\n";
  std::string e = error_of(text);
  EXPECT_NE(e.find(text.string() + ": not an ONNX model"), std::string::npos) << e;
  e = error_of(make_model(dir, "gray_input"));
  EXPECT_NE(e.find("input 'image' has shape [1, 1, 12, 16]"), std::string::npos) << e;
  EXPECT_NE(e.find("the contract"), std::string::npos) << e;
  e = error_of(make_model(dir, "rgb_output"));
  EXPECT_NE(e.find("output 'depth' has shape [1, 3, 12, 16]"), std::string::npos) << e;
  e = error_of(make_model(dir, "two_inputs"));
  EXPECT_NE(e.find("the model has 2 inputs"), std::string::npos) << e;
  e = error_of(make_model(dir, "bad_meta"));
  EXPECT_NE(e.find("metadata chungs.mean = '1, 2' must be three numbers"), std::string::npos) << e;
  for (const auto& k : {"notes.onnx", "gray_input.onnx", "rgb_output.onnx", "two_inputs.onnx", "bad_meta.onnx"})
    EXPECT_NE(error_of(dir / k).find((dir / k).string()), std::string::npos) << k;
}

// Needs neither the runtime nor the generator: the file checks come first, and a runtime that
// cannot be loaded is reported with what to install.
TEST(LearnedDepth, MissingFileOrRuntimeIsOneClearError) {
  test::TempDir dir;
  std::string e = error_of(dir / "absent.onnx");
  EXPECT_NE(e.find((dir / "absent.onnx").string() + ": the depth model does not exist"), std::string::npos) << e;
  e = error_of(dir.path());
  EXPECT_NE(e.find("is not a file"), std::string::npos) << e;
  std::ofstream(dir / "empty.onnx").close();
  e = error_of(dir / "empty.onnx");
  EXPECT_NE(e.find("is empty"), std::string::npos) << e;

  std::ofstream(dir / "model.onnx") << "x";
  const char* old = std::getenv("CHUNGS_ONNXRUNTIME");
  const std::string saved = old ? old : "";
  setenv("CHUNGS_ONNXRUNTIME", (dir / "no_such_libonnxruntime.so.1").c_str(), 1);
  e = error_of(dir / "model.onnx");
  const DepthRuntimeProbe probe = probe_depth_runtime();
  if (old)
    setenv("CHUNGS_ONNXRUNTIME", saved.c_str(), 1);
  else
    unsetenv("CHUNGS_ONNXRUNTIME");
  EXPECT_NE(e.find((dir / "model.onnx").string() + ": ONNX Runtime named by CHUNGS_ONNXRUNTIME cannot be used"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("npm install --ignore-scripts onnxruntime-node@"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  EXPECT_FALSE(probe.available);
  EXPECT_NE(probe.reason.find("no_such_libonnxruntime"), std::string::npos) << probe.reason;
}

// The model as the plane sweep's prior source: aligned to the points when the fit takes them, else
// the fallback's prior (the map points densified), else none.
TEST(LearnedPrior, AlignsTheModelToThePointsElseAsksTheFallback) {
  SKIP_WITHOUT_MODEL_TOOLS();
  test::TempDir dir;
  std::shared_ptr<const LearnedDepth> model = LearnedDepth::load(make_model(dir, "dynamic"), 1);
  const Image8 img = random_rgb(40, 30, 6);
  const ImageF pred = model->predict(img);
  const float lo = *std::min_element(pred.vec().begin(), pred.vec().end());
  const double s = 0.3, o = 0.05 - 0.3 * std::min(lo, 0.f);
  std::mt19937 rng(8);
  std::vector<DepthSample> points;
  for (int i = 0; i < 50; ++i) {
    const int x = int(rng() % 40), y = int(rng() % 30);
    points.push_back({float(x), float(y), float(1 / (s * pred(x, y) + o)), 1.f});
  }
  auto fallback = std::make_shared<MapPointPrior>(3, DensifyConfig{});
  const LearnedPrior lp(model, {}, fallback);
  EXPECT_EQ(lp.name(), "learned depth");
  const std::optional<DensePrior> p = lp.prior(img, points);
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(lp.aligned(), 1u);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) ASSERT_NEAR(p->inv_depth(x, y), s * pred(x, y) + o, 1e-4 * (s * pred(x, y) + o));

  // Four points: no fit is tried, the densified points answer.
  const std::vector<DepthSample> few(points.begin(), points.begin() + 4);
  std::optional<DensePrior> q = lp.prior(img, few);
  const std::optional<DensePrior> want = fallback->prior(img, few);
  ASSERT_TRUE(q.has_value() && want.has_value());
  EXPECT_EQ(q->inv_depth.vec(), want->inv_depth.vec());
  EXPECT_EQ(lp.refused(), 1u);
  // Points that disagree with the model (nearer where it says farther): the fit is refused.
  std::vector<DepthSample> against = points;
  for (auto& pt : against) pt.depth = float(s * pred(int(pt.x), int(pt.y)) + o);
  q = lp.prior(img, against);
  ASSERT_TRUE(q.has_value());
  EXPECT_EQ(q->inv_depth.vec(), fallback->prior(img, against)->inv_depth.vec());
  EXPECT_EQ(lp.refused(), 2u);
  EXPECT_EQ(lp.aligned(), 1u);
  // Without a fallback: no prior, the sweep goes wide.
  EXPECT_FALSE(LearnedPrior(model).prior(img, few).has_value());
  EXPECT_THROW(LearnedPrior(nullptr), Error);
}
