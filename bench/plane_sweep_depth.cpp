// Depth without weights (issue 25): the plane sweep's depth of keyframes of a sequence with
// ground-truth poses, scored against a reference depth where both are valid: the project's stereo
// depth (semi-global matching of the right image, which the sweep never sees) or a dataset's own
// depth (the synthetic street's rendered depth). Two modes per keyframe: dense on an image scaled by
// --scale, and at --samples pixels of the full image drawn as the sampler draws them (more where the
// image has structure). Optionally a prior: --prior-points reference depths with --prior-noise
// relative noise stand in for the tracker's map points, densified (prior_densify.hpp) and swept
// around; without it the sweep is wide (near..far).
//
//   bench_plane_sweep_depth [--dataset kitti:PATH|street:LENGTH_M,W,H[,SEED]] [--reference stereo|dataset] [--keyframes 5] [--first 10]
//                           [--every 20] [--window 6] [--ahead WINDOW] [--neighbours 4] [--scale 0.5] [--samples 5000]
//                           [--near 2] [--far 80] [--scene-depth 15] [--prior-points 0] [--prior-noise 0.1]
//                           [--max-rel-per-px 0.1] [--best-k 3] [--dense 1] [--stride 0] [--anchor 0.7] [--fill 1]
//                           [--json FILE] [--save DIR]
//
// --stride S: also the depth a run from one camera gives its keyframes (multiview_depth.hpp: the sweep
// at every S-th pixel of the scaled image, spread edge-aware, with the prior when --prior-points is
// given), scored against the same reference. --dense 0 skips the dense sweep (40 s a KITTI keyframe).
//
// --save: per keyframe the scaled image and both depths as 8-bit inverse depth (white near, black
// invalid) beside each other, to look at.
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/depth/multiview_depth.hpp"
#include "chungs/depth/plane_sweep.hpp"
#include "chungs/depth/prior_densify.hpp"
#include "chungs/depth/stereo_depth.hpp"
#include "chungs/eval/depth_metrics.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/synth/street_dataset.hpp"

using namespace chungs;

namespace {

struct Options {
  std::string dataset = "kitti:../shared/data/kitti_seq1", reference = "stereo", json, save;
  size_t best_k = 3, keyframes = 5, first = 10, every = 20, window = 6, neighbours = 4, samples = 5000, prior_points = 0;
  size_t stride = 0, dense = 1;
  long ahead = -1;  // later frames the neighbours may come from (-1: the window)
  double anchor = MultiviewDepthConfig().anchor_confidence;
  size_t fill = 1;  // the membrane fill of pixels without depth (run has it indoors only)
  double scale = 0.5, near = 2, far = 80, scene_depth = 15, prior_noise = 0.1, max_rel = 0.1;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) fail("option ", a, " needs a value");
    const std::string v = argv[++i];
    auto num = [&] {
      char* end = nullptr;
      const double d = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end || !std::isfinite(d) || d < 0) fail(a, ": not a number 0 or more: ", v);
      return d;
    };
    if (a == "--dataset") o.dataset = v;
    else if (a == "--reference") o.reference = v;
    else if (a == "--json") o.json = v;
    else if (a == "--save") o.save = v;
    else if (a == "--keyframes") o.keyframes = size_t(num());
    else if (a == "--first") o.first = size_t(num());
    else if (a == "--every") o.every = std::max<size_t>(1, size_t(num()));
    else if (a == "--window") o.window = size_t(num());
    else if (a == "--ahead") o.ahead = long(num());
    else if (a == "--anchor") o.anchor = num();
    else if (a == "--fill") o.fill = size_t(num());
    else if (a == "--neighbours") o.neighbours = size_t(num());
    else if (a == "--samples") o.samples = size_t(num());
    else if (a == "--prior-points") o.prior_points = size_t(num());
    else if (a == "--scale") o.scale = num();
    else if (a == "--near") o.near = num();
    else if (a == "--far") o.far = num();
    else if (a == "--scene-depth") o.scene_depth = num();
    else if (a == "--prior-noise") o.prior_noise = num();
    else if (a == "--max-rel-per-px") o.max_rel = num();
    else if (a == "--best-k") o.best_k = size_t(num());
    else if (a == "--stride") o.stride = size_t(num());
    else if (a == "--dense") o.dense = size_t(num());
    else fail("unknown option ", a);
  }
  if (o.reference != "stereo" && o.reference != "dataset") fail("--reference: stereo or dataset, not ", o.reference);
  if (!(o.scale > 0 && o.scale <= 1)) fail("--scale: in (0, 1], not ", o.scale);
  return o;
}

// kitti:PATH and the other readers' specs, or street:LENGTH_M,WIDTH,HEIGHT[,SEED] for the synthetic
// street with its rendered depth.
std::unique_ptr<Dataset> open(const std::string& spec) {
  if (spec.rfind("street:", 0) != 0) return open_dataset(spec);
  synth::StreetDatasetOptions o;
  o.depth = true;
  double seed = 1;
  if (std::sscanf(spec.c_str() + 7, "%lf,%d,%d,%lf", &o.street.length_m, &o.width, &o.height, &seed) < 3)
    fail(spec, ": street:LENGTH_M,WIDTH,HEIGHT[,SEED]");
  o.street.seed = uint64_t(seed);
  return std::make_unique<synth::StreetDataset>(o);
}

double cpu_seconds() { return double(std::clock()) / CLOCKS_PER_SEC; }
double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

Image8 scaled(const Image8& img, int w, int h) {
  if (img.width() == w && img.height() == h) return img;
  Image8 src = img, out(w, h, img.channels());
  const int type = img.channels() == 1 ? CV_8UC1 : CV_8UC3;
  cv::resize(cv::Mat(img.height(), img.width(), type, src.data()), cv::Mat(h, w, type, out.data()), cv::Size(w, h), 0,
             0, cv::INTER_AREA);
  return out;
}

// Pixels drawn with probability proportional to the Laplacian of the smoothed image, as the sampler
// favours structure.
std::vector<SweepPixel> draw_pixels(const Image8& image, size_t count, std::mt19937& rng) {
  const Image8 g = to_gray(image);
  cv::Mat src(g.height(), g.width(), CV_8UC1, const_cast<uint8_t*>(g.data())), blurred, lap;
  cv::GaussianBlur(src, blurred, cv::Size(5, 5), 1.0);
  cv::Laplacian(blurred, lap, CV_32F, 3);
  std::vector<double> w(g.pixels());
  for (int y = 0; y < g.height(); ++y)
    for (int x = 0; x < g.width(); ++x) w[size_t(y) * g.width() + x] = std::abs(lap.at<float>(y, x)) + 1e-3;
  std::discrete_distribution<size_t> pick(w.begin(), w.end());
  std::vector<SweepPixel> out;
  for (size_t i = 0; i < count; ++i) {
    const size_t p = pick(rng);
    out.push_back({int(p % size_t(g.width())), int(p / size_t(g.width()))});
  }
  return out;
}

struct Row {
  DepthErrorSum err;
  double wall = 0, cpu = 0;
  size_t asked = 0, valid = 0;
};

nlohmann::json row_json(const Row& r, size_t keyframes) {
  const DepthMetrics m = r.err.result();
  return {{"abs_rel", m.abs_rel}, {"delta1", m.delta1}, {"pixels_scored", m.pixels}, {"valid", r.valid},
          {"asked", r.asked}, {"wall_s_per_keyframe", r.wall / double(keyframes)},
          {"cpu_s_per_keyframe", r.cpu / double(keyframes)}};
}

void print_row(const char* name, const Row& r, size_t keyframes) {
  const DepthMetrics m = r.err.result();
  std::printf("%-18s valid %6.1f %%  AbsRel %.4f  d<1.25 %.4f  (%zu px scored)  wall %.2f s  cpu %.2f s per keyframe\n",
              name, 100.0 * double(r.valid) / double(std::max<size_t>(r.asked, 1)), m.abs_rel, m.delta1, m.pixels,
              r.wall / double(keyframes), r.cpu / double(keyframes));
}

int run(const Options& o) {
  const auto d = open(o.dataset);
  const DatasetInfo& info = d->info();
  if (o.reference == "stereo" && !info.has_right) fail(o.dataset, ": no right images for the stereo reference");
  if (o.reference == "dataset" && !info.has_depth) fail(o.dataset, ": no depth of its own (--reference stereo)");
  std::printf("%s: %zu frames, %s, reference %s, %zu keyframes from %zu every %zu, %zu neighbours within +-%zu, "
              "dense at scale %.2f, %zu sampled pixels, near %.1f far %.1f m, prior %s\n",
              o.dataset.c_str(), d->size(), info.camera.describe().c_str(), o.reference.c_str(), o.keyframes, o.first,
              o.every, o.neighbours, o.window, o.scale, o.samples, o.near, o.far,
              o.prior_points ? cat(o.prior_points, " points, noise ", o.prior_noise).c_str() : "none (wide sweep)");
  std::vector<SE3> poses(d->size());
  for (size_t i = 0; i < d->size(); ++i) {
    const auto p = d->gt_pose(i);
    if (!p) fail(o.dataset, ": frame ", i, " has no ground-truth pose");
    poses[i] = *p;
  }
  PlaneSweepConfig cfg;
  cfg.near = o.near, cfg.far = o.far;
  cfg.max_rel_per_px = o.max_rel;
  cfg.best_k = int(o.best_k);
  Row dense, sampled, prior_row, grid_row;
  size_t done = 0;
  std::mt19937 rng(1);
  for (size_t k = o.first; done < o.keyframes && k < d->size(); k += o.every, ++done) {
    const Frame f = d->frame(k);
    ImageF ref_depth;
    if (o.reference == "stereo") ref_depth = stereo_depth(f.left, *f.right, f.camera.fx, f.baseline).depth;
    else ref_depth = *f.depth;
    // Candidates within the window; the chosen ones by baseline and overlap.
    std::vector<SE3> cand;
    std::vector<size_t> index;
    const size_t lo = k > o.window ? k - o.window : 0, hi = std::min(d->size() - 1, k + (o.ahead < 0 ? o.window : size_t(o.ahead)));
    for (size_t j = lo; j <= hi; ++j) cand.push_back(poses[j]), index.push_back(j);
    const std::vector<size_t> chosen = select_sweep_neighbours(
        f.camera, cand, k - lo, {.count = o.neighbours, .scene_depth = o.scene_depth});
    if (chosen.empty()) fail("keyframe ", k, ": no neighbour qualifies");
    std::vector<Image8> nb_full;
    std::vector<SE3> nb_pose;
    std::string names;
    for (size_t c : chosen) {
      nb_full.push_back(d->frame(index[c]).left), nb_pose.push_back(poses[index[c]]);
      names += cat(names.empty() ? "" : ",", index[c]);
    }

    // Dense, at the scaled size.
    const int w = int(std::lround(f.camera.width * o.scale)), h = int(std::lround(f.camera.height * o.scale));
    const double sx = double(w) / f.camera.width;
    Camera cam = f.camera.scaled(sx);
    cam.width = w, cam.height = h;
    const Image8 ref_small = scaled(f.left, w, h);
    std::vector<Image8> nb_small;
    for (const Image8& im : nb_full) nb_small.push_back(scaled(im, w, h));
    PlaneSweepInput in;
    in.camera = cam;
    in.reference = {&ref_small, poses[k]};
    for (size_t j = 0; j < nb_small.size(); ++j) in.neighbours.push_back({&nb_small[j], nb_pose[j]});
    auto at_full = [&](int x, int y) {  // the reference depth under a scaled pixel
      const int X = std::clamp(int(std::lround((x + 0.5) / sx - 0.5)), 0, f.camera.width - 1);
      const int Y = std::clamp(int(std::lround((y + 0.5) / sx - 0.5)), 0, f.camera.height - 1);
      return ref_depth(X, Y);
    };
    auto score_dense = [&](const PlaneSweepDepth& out, Row& row) {
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) row.err.add(at_full(x, y), out.depth(x, y));
      row.asked += size_t(w) * size_t(h), row.valid += out.valid;
    };
    double t0 = wall_seconds(), c0 = cpu_seconds();
    const PlaneSweepDepth out = o.dense ? plane_sweep_dense(in, cfg) : PlaneSweepDepth{ImageF(w, h, 1, 0.0f), ImageF(w, h, 1, 0.0f), 0};
    dense.wall += wall_seconds() - t0, dense.cpu += cpu_seconds() - c0;
    if (o.dense) score_dense(out, dense);
    const DepthMetrics one = compare_depth([&] {
      ImageF r(w, h, 1);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) r(x, y) = at_full(x, y);
      return r;
    }(), out.depth);
    if (!o.save.empty()) {
      Image8 strip(w, 3 * h, 1, 0);
      const Image8 g = to_gray(ref_small);
      auto shade = [&](float depth) { return depth > 0 ? uint8_t(std::clamp(255.0 * o.near / depth, 20.0, 255.0)) : 0; };
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          strip(x, y) = g(x, y);
          strip(x, y + h) = shade(at_full(x, y));
          strip(x, y + 2 * h) = shade(out.depth(x, y));
        }
      write_png(std::filesystem::path(o.save) / cat("sweep_", k, ".png"), strip);
    }
    std::printf("keyframe %4zu  neighbours %-16s dense: valid %5.1f %%  AbsRel %.4f  d<1.25 %.4f\n", k, names.c_str(),
                100.0 * double(out.valid) / double(w * h), one.abs_rel, one.delta1);

    if (o.prior_points && o.dense) {
      std::vector<DepthSample> pts;
      std::normal_distribution<float> noise(0.0f, float(o.prior_noise));
      for (size_t tries = 0; pts.size() < o.prior_points && tries < 100 * o.prior_points; ++tries) {
        const int x = int(rng() % size_t(f.camera.width)), y = int(rng() % size_t(f.camera.height));
        if (ref_depth(x, y) <= 0) continue;
        pts.push_back({float((x + 0.5) * sx - 0.5), float((y + 0.5) * sx - 0.5),
                       ref_depth(x, y) * std::max(0.3f, 1.0f + noise(rng)), 1.0f});
      }
      t0 = wall_seconds(), c0 = cpu_seconds();
      const DensePrior prior = densify_prior(ref_small, pts);
      PlaneSweepInput pin = in;
      pin.prior_inv_depth = &prior.inv_depth, pin.prior_confidence = &prior.confidence;
      const PlaneSweepDepth pout = plane_sweep_dense(pin, cfg);
      prior_row.wall += wall_seconds() - t0, prior_row.cpu += cpu_seconds() - c0;
      score_dense(pout, prior_row);
    }

    if (o.stride) {
      MultiviewDepthInput min;
      min.camera = cam;
      min.reference = in.reference;
      min.neighbours = in.neighbours;
      std::normal_distribution<float> noise(0.0f, float(o.prior_noise));
      for (size_t tries = 0; min.points.size() < o.prior_points && tries < 100 * o.prior_points; ++tries) {
        const int x = int(rng() % size_t(f.camera.width)), y = int(rng() % size_t(f.camera.height));
        if (ref_depth(x, y) <= 0) continue;
        min.points.push_back({float((x + 0.5) * sx - 0.5), float((y + 0.5) * sx - 0.5),
                              ref_depth(x, y) * std::max(0.3f, 1.0f + noise(rng)), 1.0f});
      }
      MultiviewDepthConfig mc;
      mc.stride = int(o.stride);
      mc.anchor_confidence = o.anchor;
      mc.fill_holes = o.fill != 0;
      mc.supervise_fill = true;  // the fill's depth positive, so that it is scored
      mc.sweep = cfg;
      const MapPointPrior prior(mc.min_prior_points, mc.densify);
      t0 = wall_seconds(), c0 = cpu_seconds();
      const MultiviewDepth g = multiview_depth(min, mc, &prior);
      grid_row.wall += wall_seconds() - t0, grid_row.cpu += cpu_seconds() - c0;
      score_dense(PlaneSweepDepth{g.depth, g.confidence, g.valid}, grid_row);
    }

    // Sampled pixels at full resolution.
    const std::vector<SweepPixel> px = draw_pixels(f.left, o.samples, rng);
    PlaneSweepInput full;
    full.camera = f.camera;
    full.reference = {&f.left, poses[k]};
    for (size_t j = 0; j < nb_full.size(); ++j) full.neighbours.push_back({&nb_full[j], nb_pose[j]});
    t0 = wall_seconds(), c0 = cpu_seconds();
    const std::vector<SweepSample> s = plane_sweep_at(full, px, cfg);
    sampled.wall += wall_seconds() - t0, sampled.cpu += cpu_seconds() - c0;
    for (size_t i = 0; i < px.size(); ++i) {
      sampled.err.add(ref_depth(px[i].x, px[i].y), s[i].depth);
      sampled.valid += s[i].depth > 0;
    }
    sampled.asked += px.size();
  }
  if (!done) fail("no keyframe: --first ", o.first, " is past the ", d->size(), " frames");
  if (o.dense) print_row("dense", dense, done);
  if (o.stride) print_row(cat("grid ", o.stride, " spread").c_str(), grid_row, done);
  if (o.prior_points && o.dense) print_row("dense with prior", prior_row, done);
  print_row("sampled", sampled, done);
  if (!o.json.empty()) {
    nlohmann::json j = {{"dataset", o.dataset}, {"reference", o.reference}, {"keyframes", done},
                        {"scale", o.scale}, {"dense", row_json(dense, done)}, {"sampled", row_json(sampled, done)}};
    if (o.prior_points && o.dense) j["dense_with_prior"] = row_json(prior_row, done);
    if (o.stride) j["grid_spread"] = row_json(grid_row, done), j["stride"] = o.stride;
    std::ofstream(o.json) << j.dump(2) << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_plane_sweep_depth: %s\n", e.what());
    return 1;
  }
}
