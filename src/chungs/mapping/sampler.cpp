#include "chungs/mapping/sampler.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <map>
#include <unordered_map>

#include "chungs/depth/guessed_depth.hpp"
#include "chungs/mapping/log_probability.hpp"

namespace chungs {

void SamplerConfig::validate() const {
  // Infinite values passed `> 0` and changed the run without a word (density inf sampled 6x the map).
  if (!(density > 0) || !std::isfinite(density)) fail("sampler: density must be a finite number > 0, got ", density);
  if (!(empty_floor >= 0 && empty_floor <= 1)) fail("sampler: empty_floor must be in [0, 1], got ", empty_floor);
  if (!(init_opacity > 0 && init_opacity < 1)) fail("sampler: init_opacity must be in (0, 1), got ", init_opacity);
  if (!(min_scale_px > 0) || !std::isfinite(min_scale_px))
    fail("sampler: min_scale_px must be a finite number > 0, got ", min_scale_px);
  if (!(max_scale_fraction > 0) || !(max_scale_fraction <= 1))
    fail("sampler: max_scale_fraction must be in (0, 1] of the image width, got ", max_scale_fraction);
  if (!(new_per_step >= 0) || !std::isfinite(new_per_step)) fail("sampler: new_per_step must be >= 0, got ", new_per_step);
  if (!(min_per_chunk_per_100k_px >= 0) || !(min_per_chunk_per_100k_px <= 1e5))
    fail("sampler: min_per_chunk_per_100k_px must be in [0, 100000], got ", min_per_chunk_per_100k_px);
  if (stride < 1) fail("sampler: stride must be >= 1, got ", stride);
  if (!(fill_depth >= 0)) fail("sampler: fill_depth must be >= 0, got ", fill_depth);
  if (resample_every < 0) fail("sampler: resample_every must be >= 0, got ", resample_every);
  // The pool holds up to this many keyframes' held-back picks in host memory, outside the budget.
  if (stray_wait_keyframes < 0 || stray_wait_keyframes > 1000)
    fail("sampler: stray_wait_keyframes must be in [0, 1000], got ", stray_wait_keyframes);
}

namespace {

// A uniform in [0, 1) for counter i of stream `key` (splitmix64's finaliser): stateless, so any
// pixel's draw can be made on any thread.
inline double counter_uniform(uint64_t key, uint64_t i) {
  uint64_t z = key + (i + 1) * 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return double(z >> 11) * 0x1.0p-53;
}

struct Pick {
  int x, y;
  float p, z;
  bool filled;  // z is the fill depth, not a measurement
  Eigen::Vector3d pw;
  ChunkId id;
};

}  // namespace

float sh_dc_of_colour(float c) { return (c - 0.5f) / 0.28209479177387814f; }

namespace {

// One Gaussian per pick, grouped by chunk in ascending id order.
std::vector<ChunkBatch> build_batches(const SamplerConfig& config, const ImageF& image, const Camera& camera, int s,
                                      uint32_t keyframe_id, uint32_t step, const std::vector<Pick>& picks) {
  const double max_px = config.max_scale_fraction * image.width();
  // Clamped between bounds the wrong way round, every footprint was held to the upper one without a word.
  if (config.min_scale_px > max_px)
    fail("sampler: min_scale_px ", config.min_scale_px, " exceeds max_scale_fraction x the image width (",
         config.max_scale_fraction, " x ", image.width(), " = ", max_px, " px)");
  const int ch = image.channels();
  // Each chunk's block is sized once (growing it a Gaussian at a time cost more than the draws).
  std::map<ChunkId, GaussianBlock> by_chunk;
  {
    std::unordered_map<ChunkId, size_t> counts;
    for (const Pick& pk : picks) ++counts[pk.id];
    for (const auto& [id, n] : counts) by_chunk[id].resize(n);
  }
  std::unordered_map<ChunkId, std::pair<GaussianBlock*, size_t>> cursor;
  for (auto& [id, b] : by_chunk) cursor[id] = {&b, 0};
  for (const Pick& pk : picks) {
    const double z = pk.z;
    auto& [bp, i] = cursor[pk.id];
    GaussianBlock& b = *bp;
    auto& q = b.params;
    for (int k = 0; k < 3; ++k) q.mean[3 * i + k] = float(pk.pw[k]);
    const double px = std::clamp(double(s) / std::sqrt(double(pk.p)), config.min_scale_px, max_px);
    const float ls = float(std::log(px * z / camera.fx));
    for (int k = 0; k < 3; ++k) q.log_scale[3 * i + k] = ls;
    q.rotation[4 * i] = 1;
    q.opacity[i] = float(std::log(config.init_opacity / (1 - config.init_opacity)));
    for (int c = 0; c < 3; ++c) q.sh[48 * i + c] = sh_dc_of_colour(image(pk.x, pk.y, ch == 1 ? 0 : c));
    b.created_by_keyframe[i] = keyframe_id;
    b.created_at_step[i] = step;
    b.lr_position_factor[i] = 1.f;
    ++i;
  }
  std::vector<ChunkBatch> out;
  for (auto& [id, block] : by_chunk) out.push_back({id, std::move(block)});
  return out;
}

}  // namespace

ImageF sampling_probability(const SamplerConfig& config, const ImageF& image, const ImageF* render,
                            const ImageF* render_alpha) {
  config.validate();
  ImageF p = log_probability(image);
  ImageF pr;
  if (render) {
    if (!render->same_size(image)) fail("sampler: render and keyframe image differ in size");
    pr = log_probability(*render);
  }
  if (render_alpha && !render_alpha->same_size(image)) fail("sampler: render alpha and keyframe image differ in size");
  for (int y = 0; y < p.height(); ++y)
    for (int x = 0; x < p.width(); ++x) {
      double v = p(x, y) - (render ? pr(x, y) : 0.f);
      v = config.density * std::max(v, 0.0);
      if (render_alpha && (*render_alpha)(x, y) < 0.5f) v = std::max(v, config.empty_floor);
      p(x, y) = float(std::min(v, 1.0));
    }
  return p;
}

std::vector<ChunkBatch> sample_gaussians(const SamplerConfig& config, const ImageF& image, const ImageF& depth,
                                         const ImageF& probability, const Camera& camera, const SE3& pose,
                                         const ChunkGrid& grid, uint32_t keyframe_id, uint32_t step,
                                         std::mt19937_64& rng, SampleStats* stats,
                                         const std::unordered_set<ChunkId>* exclude, uint64_t max_new,
                                         const std::vector<Eigen::Vector3d>* seeds, const RefineDepths* refine,
                                         const std::unordered_set<ChunkId>* established,
                                         std::vector<ChunkBatch>* strays) {
  config.validate();
  if (!depth.same_size(image) || !probability.same_size(image) || depth.channels() != 1)
    fail("sampler: image ", image.width(), "x", image.height(), ", depth ", depth.width(), "x", depth.height(),
         " and probability ", probability.width(), "x", probability.height(), " must have the same size");
  SampleStats st;
  max_new = config.new_gaussian_limit(max_new);
  // The accept/reject draws come from a counter-based stream keyed by one draw of `rng`, so bands of
  // rows run on several threads and give the same picks whatever their number (in row order).
  const uint64_t key = rng();
  const int s = config.stride;
  constexpr int kBands = 32;
  const int rows = (image.height() + s - 1) / s;
  std::vector<std::vector<Pick>> band_picks(kBands);
  std::vector<SampleStats> band_stats(kBands);
  auto sample_band = [&](int band) {
    std::vector<Pick>& picks = band_picks[size_t(band)];
    SampleStats& bs = band_stats[size_t(band)];
    for (int r = band * rows / kBands; r < (band + 1) * rows / kBands; ++r) {
      const int y = r * s;
      const float* prow = &probability(0, y);
      const float* drow = &depth(0, y);
      for (int x = 0; x < image.width(); x += s) {
        const float p = prow[x];
        // With a stride each visited pixel stands for s^2 pixels.
        if (p <= 0 || counter_uniform(key, uint64_t(y) * uint64_t(image.width()) + uint64_t(x)) >= p)
          continue;
        ++bs.candidates;
        float z = placement_depth(drow[x]);
        const bool filled = !(z > 0) || !std::isfinite(z);
        if (filled) {
          ++bs.no_depth;
          if (!(config.fill_depth > 0)) continue;
          z = float(config.fill_depth);
        }
        picks.push_back({x, y, p, z, filled, {}, 0});
      }
    }
  };
  // An exception must not leave an OpenMP region (it ends the process): each band keeps its own,
  // and the first band's is thrown here, so the error is the same whatever the threads did.
  std::vector<std::exception_ptr> band_error(kBands);
#pragma omp parallel for schedule(dynamic, 1) num_threads(4)
  for (int band = 0; band < kBands; ++band) {
    try {
      sample_band(band);
    } catch (...) {
      band_error[size_t(band)] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : band_error)
    if (e) std::rethrow_exception(e);
  std::vector<Pick> picks;
  for (int band = 0; band < kBands; ++band) {
    const SampleStats& bs = band_stats[size_t(band)];
    st.candidates += bs.candidates, st.no_depth += bs.no_depth;
    picks.insert(picks.end(), band_picks[size_t(band)].begin(), band_picks[size_t(band)].end());
  }
  if (refine && *refine) {
    std::vector<PixelDepth> measured;
    std::vector<size_t> of;
    for (size_t i = 0; i < picks.size(); ++i)
      if (!picks[i].filled) measured.push_back({picks[i].x, picks[i].y, picks[i].z}), of.push_back(i);
    (*refine)(measured);
    if (measured.size() != of.size())
      fail("sampler: the depth refinement returned ", measured.size(), " pixels for ", of.size());
    for (size_t k = 0; k < of.size(); ++k)
      if (measured[k].depth > 0 && std::isfinite(measured[k].depth)) picks[of[k]].z = measured[k].depth;
  }
  // Points and chunks after the refinement, which moves them along their rays.
  {
    size_t kept = 0;
    for (Pick& pk : picks) {
      pk.pw = pose * camera.unproject(Eigen::Vector2d(pk.x, pk.y), pk.z);
      pk.id = grid.for_view(pk.pw, pose.t);
      // The map holds this place in a chunk the render left out: what looks missing is on disk.
      if (exclude && exclude->count(pk.id)) {
        ++st.excluded;
        continue;
      }
      picks[kept++] = pk;
    }
    picks.resize(kept);
  }
  if (seeds) {
    const SE3 T_cw = pose.inverse();
    for (const Eigen::Vector3d& X : *seeds) {
      if (!X.allFinite()) continue;
      const Eigen::Vector3d pc = T_cw * X;
      if (!(pc.z() > 1e-6)) continue;
      const Eigen::Vector2d uv = camera.project(pc);
      const long x = std::lround(uv.x()), y = std::lround(uv.y());
      if (!(x >= 0 && y >= 0 && x < image.width() && y < image.height())) continue;
      const ChunkId id = grid.for_view(X, pose.t);
      if (exclude && exclude->count(id)) {
        ++st.excluded;
        continue;
      }
      const float p = std::max(probability(int(x), int(y)), float(kSeedMinProbability));
      // The footprint rule below divides by the stride a drawn pixel stands for: a seed is one point.
      picks.push_back({int(x), int(y), p * float(s * s), float(pc.z()), false, X, id});
      ++st.seeds;
    }
  }
  std::vector<Pick> stray;
  // Stray points (chunks that would get only a few) go before the cap, so a cap thins every chunk
  // alike instead of pushing them all under the threshold.
  {
    std::unordered_map<ChunkId, uint64_t> per_chunk;
    for (const Pick& pk : picks) ++per_chunk[pk.id];
    const uint64_t least = config.min_per_chunk(image.pixels(), grid.size);
    // A place that enters the view a few pixels at a time (a turn's side, the far end of the street)
    // gives each keyframe only a few picks in its chunk: once the chunk exists, they are kept.
    const auto small = [&](const Pick& pk) {
      return per_chunk[pk.id] < least && !(established && established->count(pk.id));
    };
    const auto end = std::stable_partition(picks.begin(), picks.end(), [&](const Pick& pk) { return !small(pk); });
    st.dropped_small_chunks = uint64_t(picks.end() - end);
    stray.assign(end, picks.end());
    picks.erase(end, picks.end());
  }
  if (max_new && picks.size() > max_new) {
    std::shuffle(picks.begin(), picks.end(), rng);
    st.capped = picks.size() - max_new;
    picks.resize(max_new);
  }
  std::vector<ChunkBatch> out = build_batches(config, image, camera, s, keyframe_id, step, picks);
  for (const ChunkBatch& b : out) st.kept += b.block.size();
  st.chunks = out.size();
  if (strays) *strays = build_batches(config, image, camera, s, keyframe_id, step, stray);
  if (stats) *stats = st;
  return out;
}

uint64_t keep_random_subset(std::vector<ChunkBatch>& batches, uint64_t n, std::mt19937_64& rng) {
  uint64_t total = 0;
  for (const ChunkBatch& b : batches) total += b.block.size();
  if (total <= n) return 0;
  // Which of the `total` go, by their place in the batches' concatenation.
  std::vector<uint32_t> order(total);
  for (uint64_t i = 0; i < total; ++i) order[i] = uint32_t(i);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<uint8_t> keep(total, 0);
  for (uint64_t i = 0; i < n; ++i) keep[order[i]] = 1;
  std::vector<ChunkBatch> out;
  uint64_t at = 0;
  for (ChunkBatch& b : batches) {
    ChunkBatch kept{b.id, {}};
    for (size_t i = 0; i < b.block.size(); ++i)
      if (keep[at + i]) kept.block.append(b.block, i);
    at += b.block.size();
    if (kept.block.size()) out.push_back(std::move(kept));
  }
  batches = std::move(out);
  return total - n;
}

}  // namespace chungs
