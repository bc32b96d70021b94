// Learned monocular depth (issue 25): what a keyframe's prior costs besides the network itself. The
// median/MAD fit and the aligned prior (inverse depth, confidence) on a prediction of the keyframe's
// size, and, given a model, LearnedDepth::predict on a keyframe-sized image: the resize in and out,
// the planes, the tensor and the runtime's run (for a real network, its compute).
//
//   bench_learned_depth [--model FILE.onnx] [--width 1241] [--height 376] [--points 500] [--repeat 10]
//                       [--threads 0] [--json FILE]
//
// --threads: the runtime's threads per run (0: its default, one per core).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/depth/learned_depth.hpp"

using namespace chungs;

namespace {

struct Timing {
  double mean_ms = 0, min_ms = 1e300;
};

template <typename F>
Timing time_it(int repeat, F&& f) {
  Timing t;
  for (int i = 0; i < repeat; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    t.mean_ms += ms / repeat;
    t.min_ms = std::min(t.min_ms, ms);
  }
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string model, json;
    int width = 1241, height = 376, points = 500, repeat = 10, threads = 0;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) fail(a, " needs a value");
        return argv[++i];
      };
      if (a == "--model") model = next();
      else if (a == "--width") width = std::stoi(next());
      else if (a == "--height") height = std::stoi(next());
      else if (a == "--points") points = std::stoi(next());
      else if (a == "--repeat") repeat = std::stoi(next());
      else if (a == "--threads") threads = std::stoi(next());
      else if (a == "--json") json = next();
      else fail("unknown argument ", a);
    }
    if (width < 16 || height < 16 || points < 5 || repeat < 1) fail("bad sizes, points or repeat");
    std::mt19937 rng(1);
    // A relative prediction with structure (a ramp, a step) and points that follow it with noise and
    // 10 % outliers, as map points would.
    ImageF pred(width, height, 1);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) pred(x, y) = 0.5f + 2.f * y / height + (x > width / 2 && x < width / 2 + 40 ? 1.f : 0.f);
    std::uniform_real_distribution<float> u(0, 1);
    std::vector<DepthSample> samples;
    for (int i = 0; i < points; ++i) {
      DepthSample s;
      s.x = u(rng) * (width - 1), s.y = u(rng) * (height - 1);
      float inv = 0.3f * pred(int(s.x + 0.5f), int(s.y + 0.5f)) + 0.02f;
      inv *= 1 + 0.01f * (u(rng) - 0.5f);
      if (u(rng) < 0.1f) inv *= 3;
      s.depth = 1 / inv;
      samples.push_back(s);
    }
    nlohmann::json out = {{"width", width}, {"height", height}, {"points", points}, {"repeat", repeat}};
    AlignedDepth a;
    const Timing fit = time_it(repeat, [&] { a = align_inverse_depth(pred, samples); });
    if (!a.fit.ok) fail("the fit was refused: ", a.fit.refused);
    std::printf("%-44s %9s %9s\n", "", "mean ms", "min ms");
    std::printf("%-44s %9.2f %9.2f   (scale %.4f, %zu of %zu inliers)\n", "fit + aligned prior", fit.mean_ms,
                fit.min_ms, a.fit.scale, a.fit.inliers, a.fit.samples);
    out["fit_ms"] = {{"mean", fit.mean_ms}, {"min", fit.min_ms}};
    if (!model.empty()) {
      auto m = LearnedDepth::load(model, threads);
      Image8 img(width, height, 3);
      for (auto& v : img.vec()) v = uint8_t(rng() % 256);
      m->predict(img);  // the runtime's first run allocates its arenas
      const Timing p = time_it(repeat, [&] { m->predict(img); });
      std::printf("%-44s %9.2f %9.2f\n", "predict (resize, planes, run, resize back)", p.mean_ms, p.min_ms);
      std::printf("model: %s\n", m->describe().c_str());
      out["predict_ms"] = {{"mean", p.mean_ms}, {"min", p.min_ms}};
      out["model"] = m->describe();
    }
    if (!json.empty()) std::ofstream(json) << out.dump(2) << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_learned_depth: %s\n", e.what());
    return 1;
  }
}
