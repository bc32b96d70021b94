// Sampler: where a new keyframe adds Gaussians. A pixel is taken with probability
// density * max(P_LoG(keyframe) - P_LoG(render), 0): detail the map does not reproduce yet. Its
// Gaussian sits at the pixel's depth, isotropic, clamp(1/sqrt(P), min, W/10) pixels wide (so sparse
// samples in smooth regions cover their share of the image), with the pixel's colour and a low
// opacity. New Gaussians are grouped by chunk; chunks receiving too few are dropped (stray points
// would otherwise create chunk files of a handful of Gaussians).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <unordered_set>
#include <vector>

#include "chungs/depth/depth_refine.hpp"
#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/image/image.hpp"
#include "chungs/store/chunk_id.hpp"

namespace chungs {

struct SamplerConfig {
  double density = 2.0;            // acceptance = density * (P - P_render)  (paper: 2)
  double empty_floor = 0.02;       // least probability where the render is empty (alpha < 0.5)
  double init_opacity = 0.07;      // opacity of a new Gaussian (paper: 0.07)
  double min_scale_px = 1.0;       // footprint clamp, pixels: [min, max_scale_fraction * W]
  double max_scale_fraction = 0.1;
  // New chunks receiving fewer new Gaussians than this per 100 k pixels of the image get none (stray
  // points would make chunk files of a few Gaussians); a chunk the map already holds keeps any number.
  // The paper's 100 at 1241x376 is 21.43 per 100 k pixels; a count fixed in Gaussians emptied whole
  // chunks at lower resolutions (310x94: 97 of the 300 m street's ~400 chunks got any, 3 dB below
  // 620x188).
  double min_per_chunk_per_100k_px = 21.43;
  // ... but never fewer than this many. Below it chunk files hold a few Gaussians each (310x94: 1,387
  // chunks for 36 k Gaussians at 6, 407 at 25), and under a budget the steps wait on many more chunk loads
  // (at 25, the RealtimeStreet test's budgeted real-time cell waited on 109 loads in 350 steps).
  uint64_t min_per_chunk_floor = 50;
  // A new chunk's picks held back by that rule wait this many keyframes (0: dropped at once) for
  // later keyframes' picks in the same chunk; the chunk is made once they reach the threshold together.
  // Dropped at once, the far end of the street and the side a turn reveals, which enter the view a
  // few pixels per keyframe, were never sampled.
  int stray_wait_keyframes = 20;
  // The threshold in Gaussians for an image of `pixels` pixels and chunks of `chunk_size_m`. Both counts
  // above are for the paper's 10 m chunks and scale with a chunk's face area: a chunk of 5 m holds a
  // quarter of the surface, so a threshold fixed at 10 m's held back most of its picks (600 m street at
  // 310x94, 5 m chunks: 129 k picks forgotten, -0.37 dB against 10 m chunks; scaled, +0.1 dB).
  static constexpr double kThresholdChunkM = 10.0;
  uint64_t min_per_chunk(size_t pixels, double chunk_size_m) const {
    const double area = (chunk_size_m / kThresholdChunkM) * (chunk_size_m / kThresholdChunkM);
    const double least = std::max(double(min_per_chunk_floor), min_per_chunk_per_100k_px * double(pixels) / 1e5);
    return std::max<uint64_t>(1, uint64_t(std::llround(least * area)));
  }
  uint64_t max_per_keyframe = 0;   // 0: no cap; else a uniform random subset of this size
  // The cap on a keyframe's new Gaussians given the mapper's (0: none): the smaller of the two set.
  uint64_t new_gaussian_limit(uint64_t cap) const {
    return max_per_keyframe && (cap == 0 || max_per_keyframe < cap) ? max_per_keyframe : cap;
  }
  // The mapper caps a keyframe's new Gaussians at this many per 100 k pixels per optimisation step
  // that keyframes got lately (0: no cap): with few steps per keyframe (a fast intake) new
  // Gaussians would pile up untrained.
  double new_per_step = 150;
  int stride = 1;                  // consider every stride-th pixel per axis (coarse maps, tests)
  // Pixels without depth (sky, beyond the stereo range) get this depth in metres (0: skipped), so
  // the far field is drawn instead of showing the background.
  double fill_depth = 0;
  // Once this many optimisation steps have passed without sampling (0: never), the keyframe just
  // trained on is sampled again where its render still lacks the image's detail, so a place trained
  // longer can gain Gaussians as pruning removes others. Counted from the last sampling, arrivals
  // included: an intake delivering a keyframe at least this often is sampled only on arrival. Off: on
  // the 2 km street with the 600 m cell it gave nothing at 100-300 steps (bench/README, issue 20).
  int resample_every = 0;
  // The tracker's sparse map points seen by a keyframe (--poses track) also become Gaussians of it,
  // beside the drawn pixels, at the points' positions (the paper's "sparse point cloud ... provides one
  // source of Gaussians"), each point once.
  bool map_point_seeds = true;
  void validate() const;
};

struct SampleStats {
  uint64_t candidates = 0;  // pixels accepted by the Bernoulli draw
  uint64_t no_depth = 0;    // ... without valid depth
  uint64_t kept = 0;        // Gaussians returned
  uint64_t dropped_small_chunks = 0;  // ... in new chunks that got too few (held back)
  uint64_t released_strays = 0;       // held back earlier, now in a chunk of their own (in kept)
  uint64_t excluded = 0;  // ... whose point lies in a chunk the render left out (held on disk)
  uint64_t capped = 0;    // ... beyond the cap on new Gaussians
  uint64_t seeds = 0;     // map points in view taken as Gaussians (before the chunk and cap rules)
  size_t chunks = 0;
};

struct ChunkBatch {
  ChunkId id = 0;
  GaussianBlock block;
};

// The per-pixel acceptance probability (1 channel): density * max(P_image - P_render, 0), raised
// to empty_floor where render_alpha < 0.5. render / render_alpha may be null (empty map).
ImageF sampling_probability(const SamplerConfig& config, const ImageF& image, const ImageF* render,
                            const ImageF* render_alpha);

// May replace the depths of drawn pixels (each pixel once; the measured depth in, the one to place the
// Gaussian at out): called once per sampling, with the drawn pixels that have a depth of their own
// (not fill depth, not seeds), before their points and chunks are computed.
using RefineDepths = std::function<void(std::vector<PixelDepth>&)>;

// Samples Gaussians for a keyframe, at most one per pixel (run_mapping counts on it to tell whether
// a dataset can fill the budget), each in the chunk `grid` gives it for a view from the camera (the far level
// of a distant cube, chunk_id.hpp). image: float colour (1 or 3 channels, [0,1]); depth: metres,
// 0 invalid, negative where a guess (depth/guessed_depth.hpp: placed at its magnitude), same size.
// Points falling in a chunk of `exclude` are not taken (the map holds that
// place but the render that set the probability left it out); of the rest at most max_new (0: no
// cap; config.max_per_keyframe caps too), a uniform random subset. Returns batches by chunk in
// ascending id order. seeds (world points, may be null): each one in front of the camera and inside
// the image is taken as well, without a draw, at its own position, coloured by its pixel and sized
// like a drawn pixel's Gaussian at its depth (its acceptance probability, at least kSeedMinProbability).
// refine (may be null): see RefineDepths; a depth it returns that is not positive and finite keeps the
// measured one. established (may be null): chunks the map already holds Gaussians in; the
// min_per_chunk rule, meant against new chunks for a few stray points, does not apply to them.
// strays (may be null): receives the picks that rule held back, built like the others, by chunk.
std::vector<ChunkBatch> sample_gaussians(const SamplerConfig& config, const ImageF& image, const ImageF& depth,
                                         const ImageF& probability, const Camera& camera, const SE3& pose,
                                         const ChunkGrid& grid, uint32_t keyframe_id, uint32_t step,
                                         std::mt19937_64& rng, SampleStats* stats = nullptr,
                                         const std::unordered_set<ChunkId>* exclude = nullptr,
                                         uint64_t max_new = 0, const std::vector<Eigen::Vector3d>* seeds = nullptr,
                                         const RefineDepths* refine = nullptr,
                                         const std::unordered_set<ChunkId>* established = nullptr,
                                         std::vector<ChunkBatch>* strays = nullptr);
// Keeps a uniform random subset of `n` of the batches' Gaussians (all when they are fewer), dropping
// batches left empty; returns how many went.
uint64_t keep_random_subset(std::vector<ChunkBatch>& batches, uint64_t n, std::mt19937_64& rng);

// A seed where the render already shows the image's detail (probability 0) is sized as a pixel drawn
// with this probability (10 pixels across), not as the sampler's largest footprint.
constexpr double kSeedMinProbability = 0.01;

// SH DC coefficient for a colour value c in [0, 1] (renders as 0.5 + C0 * dc).
float sh_dc_of_colour(float c);

}  // namespace chungs
