#include "chungs/config/config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <type_traits>
#include <utility>
#include <vector>

#include "chungs/common/decimal.hpp"
#include "chungs/common/text_file.hpp"

namespace chungs {

namespace {

// Each section lists its fields once; the same list drives loading and printing.
template <class V>
void fields(V& v, ChunkStoreConfig& c) {
  v("chunk_size", c.chunk_size, "metres, edge of a cubic chunk (a new map; an existing map keeps its own)");
  v("sh_degree", c.sh_degree, "spherical-harmonics degree stored in a new map");
  v("compress", c.compress, "zstd-compress chunk files");
  v("zstd_level", c.zstd_level, "");
  v("shuffle", c.shuffle, "byte-shuffle before zstd");
  v("durable", c.durable, "power-loss safe at each commit (checkpoint); saves are not flushed one by one");
  v("half_moments", c.half_moments, "store Adam moments as binary16 in chunk files (724 -> 488 bytes per Gaussian)");
  v("half_sh_rest", c.half_sh_rest, "store SH beyond DC as binary16 too (-> 398 bytes per Gaussian)");
  v("verify_on_open", c.verify_on_open, "check every chunk checksum when a map is opened");
}
template <class V>
void fields(V& v, KeyframeStoreConfig& c) {
  v("max_in_memory", c.max_in_memory, "keyframes kept in memory, the rest on disk (LRU)");
  v("compress", c.compress, "");
  v("zstd_level", c.zstd_level, "");
  v("durable", c.durable, "power-loss safe at each commit (checkpoint)");
  v("background", c.background, "writes and read-ahead on the store's own thread");
}
template <class V>
void fields(V& v, ResidencyConfig& c) {
  v("budget_gaussians", c.budget_gaussians, "Gaussians resident in (GPU) memory at most");
  v("eviction_hysteresis", c.eviction_hysteresis, "fraction of the budget evicted beyond the shortfall");
  v("async_io", c.async_io, "background prefetch and write-behind");
  v("prefetch_max_gaussians", c.prefetch_max_gaussians,
    "host read-ahead, Gaussians; 0: 1/32 of the budget, at least 160000 or the budget");
  v("write_behind_max_gaussians", c.write_behind_max_gaussians, "queued writes, Gaussians; 0: 1/8 of the budget, at least 160000 or half the budget");
  v("flush_threads", c.flush_threads, "threads writing modified chunks at a checkpoint the caller waits for");
  v("write_behind_threads", c.write_behind_threads, "chunk I/O threads behind the optimiser, each reading ahead and writing evicted modified chunks; 0: one per core, 4 to 16");
  v("checkpoint_threads", c.checkpoint_threads, "threads writing a checkpoint behind the optimiser");
  v("pool_headroom", c.pool_headroom, "pool slots beyond the budget (fraction), used only by loop corrections");
}
template <class V>
void fields(V& v, CullerConfig& c) {
  v("near", c.near, "metres");
  v("far", c.far, "far plane, metres");
  v("max_distance", c.max_distance, "distance filter on a chunk's nearest point, metres");
  v("cache_translation", c.cache_translation, "reuse a keyframe's result while it moves less than this x chunk size");
  v("cache_rotation_rad", c.cache_rotation_rad, "... and turns less than this");
  v("cache_max_entries", c.cache_max_entries, "");
  v("parallel_min_chunks", c.parallel_min_chunks, "");
  v("far_level_distance", c.far_level_distance,
    "beyond this distance (metres) a view draws and trains a chunk's far level; 0: one level (a map keeps its own)");
}
template <class V>
void fields(V& v, RasterConfig& c) {
  v("near_plane", c.near_plane, "metres");
  v("low_pass", c.low_pass, "px^2 added to each 2D covariance");
  v("small_image_reference_px", c.small_image_reference_px,
    "below this many pixels, low_pass x pixels / reference, at least 1/16 (0: off)");
  v("antialias", c.antialias, "scale a splat's opacity by what the low-pass widened it (keeps far looks)");
  v("alpha_max", c.alpha_max, "");
  v("min_alpha", c.min_alpha, "");
  v("min_transmittance", c.min_transmittance, "");
  v("extent_sigma", c.extent_sigma, "");
  v("guard_band", c.guard_band, "");
  v("sh_degree", c.sh_degree, "");
  v("background", c.background, "RGB behind the splats");
  v("segment_entries", c.segment_entries,
    "GPU: tiles with more entries are composited in segments of this many (0: off)");
}
template <class V>
void fields(V& v, LossConfig& c) {
  v("lambda_ssim", c.lambda_ssim, "weight of 1 - SSIM against L1");
  v("lambda_depth", c.lambda_depth, "inverse-depth L1 weight: 0.1 indoor, 1.0 KITTI");
}
template <class V>
void fields(V& v, AdamConfig& c) {
  v("lr_position", c.lr_position, "metres (the paper: 1e-3 outdoor, 5e-5 indoor; here 1e-3 both)");
  v("multiview_position_factor", c.multiview_position_factor,
    "one camera (depth from the plane sweep): lr_position is multiplied by this");
  v("position_decay", c.position_decay, "position lr factor per visit");
  v("position_lr_floor", c.position_lr_floor, "lowest position lr factor");
  v("lr_sh_dc", c.lr_sh_dc, "");
  v("lr_sh_rest", c.lr_sh_rest, "");
  v("lr_opacity", c.lr_opacity, "on the opacity logit (the paper: 0.1)");
  v("lr_scale", c.lr_scale, "");
  v("lr_rotation", c.lr_rotation, "");
  v("beta1", c.beta1, "");
  v("beta2", c.beta2, "");
  v("eps", c.eps, "");
  v("small_image_reference_px", c.small_image_reference_px,
    "below this many pixels, opacity, colour and scale rates x sqrt(reference / pixels), at most 4 (0: off)");
  v("reference_steps", c.reference_steps,
    "keyframes trained more steps each get opacity, colour and scale rates x sqrt(reference / steps) (0: off)");
}
template <class V>
void fields(V& v, PruneConfig& c) {
  v("min_opacity", c.min_opacity, "");
  v("max_radius_fraction", c.max_radius_fraction,
    "screen radius limit as a fraction of image width (0: off; the paper: 0.5)");
  v("every", c.every, "iterations between pruning passes");
  v("min_visits", c.min_visits, "steps a Gaussian was visible in before the opacity test applies (0: from birth)");
}

template <class V>
void fields(V& v, MapperConfig& c) {
  v("pacing", c.pacing, "fixed (iterations per keyframe, deterministic) | anytime (real-time intake)");
  v("iterations_per_keyframe", c.iterations_per_keyframe, "fixed pacing: optimisation steps per keyframe");
  v("final_iterations", c.final_iterations,
    "refinement steps after the last frame, spread over every keyframe (-1: one a keyframe; under fixed pacing at least 4 x "
    "iterations_per_keyframe)");
  v("refinement_rounds", c.refinement_rounds,
    "rounds over the refinement's groups of keyframes: more mix the places' views better, and load each "
    "group's chunks once a round");
  v("refinement_group_steps", c.refinement_group_steps,
    "with final_iterations -1: steps each refinement group gets at least when a budget below the map makes "
    "several (at most 16 a keyframe, and at most the steps the drive took)");
  v("refinement_min_visit_steps", c.refinement_min_visit_steps,
    "a group is visited at most once per this many of its refinement steps");
  v("speed", c.speed, "anytime pacing: frames arrive at the dataset rate times this");
  v("keyframe_every", c.keyframe_every, "every k-th training frame becomes a keyframe (0: off); or when ...");
  v("keyframe_translation", c.keyframe_translation, "... the camera moved this many metres (0: off), or ...");
  v("keyframe_parallax", c.keyframe_parallax,
    "... moved this share of the last keyframe's median depth (0: off), or ...");
  v("keyframe_rotation_deg", c.keyframe_rotation_deg, "... turned this many degrees (0: off)");
  v("min_steps_per_keyframe", c.min_steps_per_keyframe,
    "anytime pacing: least steps per keyframe; keyframes a later arrived one supersedes are dropped");
  v("holdout_every", c.holdout_every, "frame i is held out (never trained) when i % n == n - 1; 0: none");
  v("frame_lookahead", c.frame_lookahead,
    "frames read ahead; keyframes are loaded and depth computed on their own threads (0: current frame only)");
  v("read_ahead_steps", c.read_ahead_steps,
    "steps whose keyframes are drawn ahead, their chunks and images read in the background");
  v("resolution", c.resolution, "image scale factor for mapping (1 = full resolution)");
  v("depth", c.depth, "auto | sensor | stereo | multiview (one camera: plane sweep against earlier keyframes) | none (= multiview for run)");
  v("checkpoint_seconds", c.checkpoint_seconds, "seconds between checkpoints (resume points; 0: off) ...");
  v("checkpoint_every", c.checkpoint_every, "... or keyframes between them (0: off) ...");
  v("checkpoint_max_share", c.checkpoint_max_share,
    "... but the optimiser time checkpoints cost, the final one included, stays below this share of the run (0: no bound)");
  v("seed", c.seed, "random seed (sampling, keyframe picks)");
  v("eval_keyframe_stride", c.eval_keyframe_stride, "score every n-th keyframe at the end (paper protocol); 0: off");
  v("max_saved_renders", c.max_saved_renders, "held-out renders written as PNG at most");
  v("lpips_weights", c.lpips_weights,
    "LPIPS weights file (scripts/lpips_convert.py) for the evaluation; empty: LPIPS not available");
  v("mono_depth_model", c.mono_depth_model,
    "monocular input: ONNX depth model (README: the contract; needs ONNX Runtime); empty: no learned depth");
  v("in_core_only", c.in_core_only,
    "comparison mode: stop when the map outgrows the budget instead of moving chunks to disk");
  v("loop_refine_iterations", c.loop_refine_iterations, "steps on the junction keyframes after a loop closure");
  v("pose_update_min_translation", c.pose_update_min_translation,
    "m: tracker keyframe moves below this (and below the rotation) are not applied to the map");
  v("pose_update_min_rotation_deg", c.pose_update_min_rotation_deg, "degrees, see pose_update_min_translation");
  v("gpu_keyframe_cache_mb", c.gpu_keyframe_cache_mb,
    "MB of VRAM keeping keyframe images for the steps on the GPU (0: upload them every step)");
}
template <class V>
void fields(V& v, SamplerConfig& c) {
  v("density", c.density, "acceptance = density * (P_LoG(image) - P_LoG(render))");
  v("empty_floor", c.empty_floor, "least acceptance where the render is empty");
  v("init_opacity", c.init_opacity, "");
  v("min_scale_px", c.min_scale_px, "footprint of a new Gaussian: clamp(1/sqrt(P), min, fraction * W) px");
  v("max_scale_fraction", c.max_scale_fraction, "");
  v("min_per_chunk_per_100k_px", c.min_per_chunk_per_100k_px,
    "chunks receiving fewer new Gaussians than this per 100 k pixels get none (the paper: 100 at 1241x376); "
    "for 10 m chunks, scaled by the chunk's face area for others");
  v("min_per_chunk_floor", c.min_per_chunk_floor, "... nor fewer than this many (0: no floor; scaled alike)");
  v("stray_wait_keyframes", c.stray_wait_keyframes,
    "keyframes a new chunk's too few picks wait for more in the same chunk (0: dropped at once)");
  v("max_per_keyframe", c.max_per_keyframe, "cap on new Gaussians per keyframe (0: none)");
  v("new_per_step", c.new_per_step,
    "new Gaussians per keyframe at most this many per 100 k pixels per step keyframes got lately (0: no cap)");
  v("stride", c.stride, "sample every n-th pixel per axis");
  v("fill_depth", c.fill_depth, "metres given to sampled pixels without depth (sky); 0: skip them");
  v("resample_every", c.resample_every,
    "steps without sampling after which the keyframe just trained on is sampled again (0: only at arrival)");
  v("map_point_seeds", c.map_point_seeds,
    "--poses track: the tracker's map points first seen by a keyframe become Gaussians of it too");
}
template <class V>
void fields(V& v, MultiviewDepthConfig& c) {
  v("stride", c.stride, "host: plane sweep every n-th pixel per axis, spread edge-aware to the rest");
  v("cuda_stride", c.cuda_stride, "the same under --device cuda");
  v("neighbours", c.neighbours, "earlier keyframes a keyframe is swept against (1 to 8)");
  v("min_prior_points", c.min_prior_points, "tracker map points in view for a prior (else the wide sweep)");
  v("min_confidence", c.min_confidence, "spread depth below this confidence is dropped");
  v("keep_keyframes", c.keep_keyframes, "recent keyframes kept (images) to choose neighbours from");
  v("anchor_confidence", c.anchor_confidence,
    "second pass: matches this confident, spread edge-aware, narrow the sweep of the rest (0: one pass)");
  v("anchor_width", c.anchor_width, "second pass: its prior is spread on the image reduced to this width (pixels)");
  v("scene_depth", c.choice.scene_depth,
    "metres, a typical depth of a view: the neighbour choice's before the run knows its depth, "
    "and one camera's tracked map unit (its first keyframe's median depth is set to this)");
  v("fill_holes", c.fill_holes,
    "pixels left without depth get a membrane fill of the others' inverse depth (not with a fill depth)");
  v("refresh_after", c.refresh_after,
    "a keyframe's guessed (filled) pixels are swept again this many keyframes later, with the later "
    "ones as neighbours; new depth replaces the guesses and moves their Gaussians (0: never)");
  v("supervise_fill", c.supervise_fill,
    "the fill's depth is also the depth loss's target (else it only places Gaussians)");
  v("near", c.sweep.near, "wide sweep from (metres; a monocular tracker's unit is scaled to its points)");
  v("far", c.sweep.far, "... to (metres)");
  v("prior_range", c.sweep.prior_range, "sweep around a prior: its inverse depth x (1 -+ this)");
  v("best_k", c.sweep.best_k, "a depth hypothesis costs the mean of its best this many neighbours' costs");
  v("min_views", c.sweep.min_views,
    "fewest neighbours that must see a patch (1 to best_k); fewer than best_k: the mean of those that do");
  v("refine", c.refine,
    "RGB-D and stereo input: polish the depth of sampled pixels by a sweep against earlier keyframes");
  v("refine_neighbours", c.refine_neighbours, "refine: earlier keyframes swept against (1 to 8)");
  v("refine_rgbd_range", c.refine_rgbd_range, "refine: sensor depth's inverse depth -+ this (1/m)");
  v("refine_stereo_range", c.refine_stereo_range, "refine: stereo depth's inverse depth -+ this (1/m)");
}
template <class V>
void fields(V& v, KeyframeSelectorConfig& c) {
  v("cell_size", c.cell_size, "metres, keyframe cell (the paper: 200)");
  v("budget_cell_size", c.budget_cell_size, "metres, the cell while the budget narrows training to a window");
  v("around_latest", c.around_latest,
    "candidates within cell_size / 2 of the latest keyframe instead of its grid cell");
  v("max_candidates", c.max_candidates, "at most this many candidates, the nearest (0: no limit)");
  v("new_uses", c.new_uses, "remaining uses of a new keyframe");
  v("top_loss_fraction", c.top_loss_fraction, "share of candidates by loss that get an extra use");
  v("budget_share", c.budget_share, "most of the budget the keyframes trained on together may need");
  v("partial_views", c.partial_views,
    "under a window, keyframes outside it are trained on the resident part of their view (no loads)");
  v("min_partial_coverage", c.min_partial_coverage,
    "least share of the image that resident part must explain, else a window keyframe is trained");
  v("best_view_share", c.best_view_share,
    "under a window, pixels of a chunk shown on less than this share of its best view's blocks are not "
    "trained once that view left the window (0: off)");
  v("core_share", c.core_share,
    "over budget, a view loads only the chunks showing this share of its pixels, largest first; the rest "
    "are drawn when resident (1: all it sees)");
  v("revisit_share", c.revisit_share,
    "share of the steps on keyframes revisit_min_distance .. cell_size / 2 behind the latest, whole, in bursts (0: off)");
  v("revisit_burst", c.revisit_burst, "steps of one revisit, on keyframes near one drawn at random");
  v("revisit_min_distance", c.revisit_min_distance, "metres behind the latest keyframe where revisits start");
  v("revisit_group_m", c.revisit_group_m, "a burst trains the keyframes within this many metres of the one drawn");
}
template <class V>
void fields(V& v, SkyConfig& c) {
  v("enabled", c.enabled, "a colour per direction behind the Gaussians, trained by every step (outdoor preset: on)");
  v("width", c.width, "texels over 360 degrees of azimuth");
  v("height", c.height, "texels over 180 degrees of elevation");
  v("lr", c.lr, "Adam step on texel colours");
}
template <class V>
void fields(V& v, StereoDepthConfig& c) {
  v("num_disparities", c.num_disparities, "search range, pixels at full resolution (at most 256)");
  v("p1", c.p1, "semi-global matching: penalty of a 1-pixel disparity step between neighbours");
  v("p2", c.p2, "semi-global matching: penalty of a larger step (census costs are 0-62)");
  v("uniqueness", c.uniqueness, "percent by which the best match must beat the others");
  v("speckle_window", c.speckle_window, "largest island of disparity (pixels) dropped as a mismatch, 0 = off");
  v("speckle_range", c.speckle_range, "pixels of disparity within which neighbours belong to one island");
  v("lr_max_diff", c.lr_max_diff, "left-right check tolerance, pixels");
  v("min_depth", c.min_depth, "metres");
  v("max_depth", c.max_depth, "metres");
  v("min_disparity_px", c.min_disparity_px, "");
  v("confidence_sigma2", c.confidence_sigma2, "");
  v("min_confidence", c.min_confidence, "pixels below this confidence get no depth");
}

template <class V>
void sections(V& v, Config& c) {
  v.section("store", c.store);
  v.section("keyframes", c.keyframes);
  v.section("residency", c.residency);
  v.section("culling", c.culling);
  v.section("raster", c.raster);
  v.section("loss", c.loss);
  v.section("adam", c.adam);
  v.section("prune", c.prune);
  v.section("mapper", c.mapper);
  v.section("sampler", c.sampler);
  v.section("selector", c.selector);
  v.section("stereo", c.stereo);
  v.section("multiview", c.multiview);
  v.section("sky", c.sky);
}

struct Printer {
  YAML::Emitter out;
  template <class T>
  void operator()(const char* key, T& value, const char* comment) {
    out << YAML::Key << key << YAML::Value;
    if constexpr (std::is_same_v<T, std::array<double, 3>>)
      out << YAML::Flow << YAML::BeginSeq << value[0] << value[1] << value[2] << YAML::EndSeq;
    else
      out << value;
    if (comment && *comment) out << YAML::Comment(comment);
  }
  template <class S>
  void section(const char* name, S& s) {
    out << YAML::Key << name << YAML::Value << YAML::BeginMap;
    fields(*this, s);
    out << YAML::EndMap;
  }
};

// The keys of a mapping with their line numbers. yaml-cpp keeps both of two equal keys and lookups
// see the first, so a repeated key (or section) was dropped without a word: it is refused, as is a
// key that is not a plain word (a list as a key failed with a bare "bad conversion").
std::vector<std::pair<std::string, int>> keys_of(const YAML::Node& map, const std::string& source,
                                                 const std::string& prefix) {
  std::vector<std::pair<std::string, int>> keys;
  std::set<std::string> seen;
  for (const auto& kv : map) {
    const int line = kv.first.Mark().line + 1;
    if (!kv.first.IsScalar())
      fail(source, ":", line, ": a key of ",
           prefix.empty() ? std::string("the file") : "section '" + prefix.substr(0, prefix.size() - 1) + "'",
           " is not a word");
    const auto k = kv.first.as<std::string>();
    if (!seen.insert(k).second) fail(source, ":", line, ": '", prefix, k, "' is given twice");
    keys.emplace_back(k, line);
  }
  return keys;
}

// Keys that were renamed or replaced: a file written for an older version names what to write now.
const std::map<std::string, std::string>& renamed_keys() {
  static const std::map<std::string, std::string> m = {
      {"sampler.min_per_chunk",
       "it became sampler.min_per_chunk_per_100k_px (21.43: the paper's 100 at 1241x376) with "
       "sampler.min_per_chunk_floor (50)"},
  };
  return m;
}

size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] != b[j - 1])});
      diag = up;
    }
  }
  return row[b.size()];
}

// What to tell a user who wrote `prefix + name`: the key that replaced it, or the nearest known name
// when it is a likely typo (at most a third of its letters differ); empty when neither.
std::string hint_for(const std::string& prefix, const std::string& name, const std::set<std::string>& known) {
  if (const auto it = renamed_keys().find(prefix + name); it != renamed_keys().end()) return ": " + it->second;
  std::string best;
  size_t best_d = name.size() / 3 + 1;
  for (const std::string& k : known) {
    // The distance is at least the difference in length: a long word is never compared in full.
    if ((name.size() > k.size() ? name.size() - k.size() : k.size() - name.size()) >= best_d) continue;
    if (const size_t d = edit_distance(name, k); d < best_d) best = k, best_d = d;
  }
  return best.empty() ? std::string() : "; did you mean '" + prefix + best + "'?";
}

struct Loader {
  YAML::Node root;
  std::string source;
  std::string section_name;
  YAML::Node node;
  std::set<std::string> seen_sections, seen_keys;

  template <class T>
  void operator()(const char* key, T& value, const char*) {
    seen_keys.insert(key);
    YAML::Node n = node[key];
    if (!n) return;
    try {
      if constexpr (std::is_same_v<T, std::array<double, 3>>) {
        if (!n.IsSequence() || n.size() != 3) throw YAML::Exception(n.Mark(), "expected a list of 3 numbers");
        for (size_t i = 0; i < 3; ++i) value[i] = n[i].as<double>();
      } else {
        if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>)
          if (!n.IsScalar() || !written_in_decimal(n.Scalar())) throw YAML::Exception(n.Mark(), "not decimal");
        value = n.as<T>();
      }
    } catch (const YAML::Exception&) {
      fail(source, ":", n.Mark().line + 1, ": ", section_name, ".", key, ": '", YAML::Dump(n),
           "' is not a valid value");
    }
  }
  template <class S>
  void section(const char* name, S& s) {
    seen_sections.insert(name);
    node = root[name];
    if (!node) return;
    if (!node.IsMap()) fail(source, ": section '", name, "' must be a mapping of key: value");
    section_name = name;
    seen_keys.clear();
    const auto keys = keys_of(node, source, section_name + ".");
    fields(*this, s);
    for (const auto& [k, line] : keys)
      if (!seen_keys.count(k))
        fail(source, ":", line, ": unknown key '", name, ".", k, "'", hint_for(section_name + ".", k, seen_keys));
  }
};

// culling and keyframes have no checks of their own (CullerConfig, KeyframeStoreConfig), and only a
// file sets them, so they are checked where a file is read: `culling: {near: -1}` and
// `keyframes: {zstd_level: 9999}` used to pass.
void validate_sections_without_checks(const Config& c) {
  const CullerConfig& k = c.culling;
  if (!(std::isfinite(k.near) && k.near > 0))
    fail("culling: near must be a positive number of metres, got ", k.near);
  if (!(std::isfinite(k.far) && k.far > k.near))
    fail("culling: far must be a finite number of metres beyond near (", k.near, "), got ", k.far);
  // Beyond that the frustum's far plane is at infinity in double precision: `far: 1e30` failed mid-run
  // with "degenerate view-projection matrix", naming no key.
  if (k.far > k.near * 1e12)
    fail("culling: far must be at most 1e12 times near (", k.near, " m), got ", k.far);
  if (!(std::isfinite(k.max_distance) && k.max_distance > 0))
    fail("culling: max_distance must be a positive number of metres, got ", k.max_distance);
  if (!(std::isfinite(k.far_level_distance) && k.far_level_distance >= 0))
    fail("culling: far_level_distance must be 0 (one level) or a positive number of metres, got ", k.far_level_distance);
  if (!(std::isfinite(k.cache_translation) && k.cache_translation >= 0))
    fail("culling: cache_translation must be 0 or more, got ", k.cache_translation);
  if (!(std::isfinite(k.cache_rotation_rad) && k.cache_rotation_rad >= 0))
    fail("culling: cache_rotation_rad must be 0 or more, got ", k.cache_rotation_rad);
  if (!(c.sampler.fill_depth <= k.far))
    fail("sampler: fill_depth must be at most culling.far (", k.far, " m), got ", c.sampler.fill_depth);
  const KeyframeStoreConfig& f = c.keyframes;
  if (f.zstd_level < 1 || f.zstd_level > 22)
    fail("keyframes: zstd_level must be in [1, 22], got ", f.zstd_level);
  // The store refused 0 only once the run had made its map folder, naming neither file nor key.
  if (f.max_in_memory < 1) fail("keyframes: max_in_memory must be at least 1, got ", f.max_in_memory);
}

}  // namespace

Config config_from_yaml(const std::string& text, const std::string& source, const Config& base) {
  Config c = base;
  Loader l;
  l.source = source;
  try {
    l.root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(source, ":", e.mark.line + 1, ": not valid YAML (", e.msg, ")");
  }
  if (l.root.IsNull()) return c;
  if (!l.root.IsMap()) fail(source, ": expected a mapping of sections (store:, residency:, ...)");
  const auto sections_given = keys_of(l.root, source, "");
  sections(l, c);
  for (const auto& [k, line] : sections_given)
    if (!l.seen_sections.count(k))
      fail(source, ":", line, ": unknown section '", k, "'", hint_for("", k, l.seen_sections));
  try {
    c.validate();
    validate_sections_without_checks(c);
  } catch (const Error& e) {
    fail(source, ": ", e.what());
  }
  return c;
}

Config load_config(const std::filesystem::path& file, const Config& base) {
  return config_from_yaml(read_file_text(file), file.string(), base);
}

std::string config_to_yaml(const Config& config) {
  Config copy = config;
  Printer p;
  // Shortest forms that read back to the same defaults (15 / 7 significant digits).
  p.out.SetDoublePrecision(15);
  p.out.SetFloatPrecision(7);
  p.out << YAML::BeginMap;
  sections(p, copy);
  p.out << YAML::EndMap;
  return std::string(p.out.c_str()) + "\n";
}

}  // namespace chungs
