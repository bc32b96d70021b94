#include "chungs/mapping/mapper.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include "chungs/common/log.hpp"
#include "chungs/common/stopwatch.hpp"
#include "chungs/mapping/sky_file.hpp"
#include "chungs/render/render_passes.hpp"
#include "chungs/render/sky.hpp"
#include "chungs/store/chunk_file_name.hpp"
#include "chungs/store/chunk_levels.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {

size_t pool_capacity(const ResidencyConfig& rc) {
  if (!(rc.pool_headroom >= 0 && rc.pool_headroom <= 4))
    fail("residency: pool_headroom must be in [0, 4], got ", rc.pool_headroom);
  return rc.budget_gaussians + size_t(double(rc.budget_gaussians) * rc.pool_headroom);
}

// A warning repeated at every keyframe would bury the rest: said the first time, and again only
// when what is needed grows by a quarter over the largest need seen so far.
bool worth_saying_again(uint64_t needed, uint64_t& largest) {
  const bool say = needed > largest * 5 / 4;
  largest = std::max(largest, needed);
  return say;
}

// What the run state committed with a lost manifest says of the map: its chunk size, SH degree and far-level
// distance (maps whose state predates them keep the settings' values; the distance then follows the chunks,
// settle_far_level_distance), and whether its keyframes saw chunks (a map whose manifest and chunk files are
// all gone then lost its Gaussians). A damaged value is refused naming the file.
struct LostMapState {
  std::optional<double> far_level_distance;
  bool keyframes_saw_chunks = false;
};
LostMapState take_map_geometry(const fs::path& state_file, ChunkStoreConfig& c) {
  LostMapState out;
  if (!fs::exists(state_file)) return out;
  const nlohmann::json j = read_json_file(state_file);
  validate_run_state(j, state_file);
  if (j.contains("chunk_size")) c.chunk_size = j["chunk_size"].get<double>();
  if (j.contains("sh_degree")) c.sh_degree = int(j["sh_degree"].get<uint64_t>());
  if (j.contains("far_level_distance")) out.far_level_distance = j["far_level_distance"].get<double>();
  if (j.contains("keyframe_chunks") && j["keyframe_chunks"].is_object())
    for (const auto& [id, chunks] : j["keyframe_chunks"].items())
      out.keyframes_saw_chunks = out.keyframes_saw_chunks || (chunks.is_array() && !chunks.empty());
  return out;
}

// The run state repeats the manifest's geometry: where they differ, one of them was damaged, and
// which is unknown, so the map is left as it is.
void require_same_geometry(const nlohmann::json& state, const fs::path& state_file, const ChunkStore& store) {
  if (state.contains("chunk_size") && state["chunk_size"].get<double>() != store.chunk_size())
    fail(state_file.string(), ": 'chunk_size' ", state["chunk_size"].dump(), " differs from the map's ",
         store.chunk_size(), " m in ", store.manifest_path().string(), "; one of them is damaged, the map is left as it is");
  if (state.contains("sh_degree") && int(state["sh_degree"].get<uint64_t>()) != store.sh_degree())
    fail(state_file.string(), ": 'sh_degree' ", state["sh_degree"].dump(), " differs from the map's ",
         store.sh_degree(), " in ", store.manifest_path().string(), "; one of them is damaged, the map is left as it is");
}

// The keyframe list must hold what the checkpoint that wrote it recorded: a list that lost lines (or
// was emptied) would drop the keyframes it no longer names, and their images with them.
void require_whole_keyframe_list(const nlohmann::json& state, const fs::path& state_file,
                                 const std::vector<KeyframeRecord>& records, const fs::path& list_file) {
  if (!state.contains("keyframe_list")) return;  // a map from before the run state recorded it
  const uint64_t count = state["keyframe_list"]["count"].get<uint64_t>();
  const uint64_t last = state["keyframe_list"]["last_id"].get<uint64_t>();
  const uint64_t have_last = records.empty() ? 0 : records.back().id;
  if (records.size() != count || have_last != last)
    fail(list_file.string(), ": lists ", records.size(), " keyframes (the last ", have_last, "), but the checkpoint "
         "that wrote it recorded ", count, " (the last ", last, ") in ", state_file.string(),
         ": the list is damaged; the map is left as it is");
}
}  // namespace

Mapper::Mapper(const fs::path& folder, const Config& config, bool resume)
    : folder_(folder), config_(config), selector_(config.selector), rng_(config.mapper.seed) {
  device_ = resolve_device(config_.mapper.device);  // before anything is written to the folder
  const bool existing = holds_a_map(folder);
  if (existing && !resume)
    fail(folder.string(), " already holds a map: pass --resume to continue it, or choose another folder");
  // With --resume too: there is no map to resume, so a map would be new among the user's files.
  if (!existing) {
    require_folder_for_new_map(folder);
    // The empty manifest of a run that ended before its first checkpoint: its chunk size and SH degree
    // would bind the new map. It names nothing; the new map writes its own.
    if (fs::exists(folder / "manifest.txt")) {
      log::info(folder.string(), ": a run ended here before its first checkpoint; starting the map afresh");
      fs::remove(folder / "manifest.txt");
    }
  }
  // The map rolls back to the last checkpoint after a crash, so it always matches the keyframe list
  // and run state committed with it (no Gaussians of frames that a resumed run processes again).
  ChunkStoreConfig store_config = config_.store;
  store_config.adopt_uncommitted = false;
  // A committed keyframe list without a manifest: the manifest was lost (or deleted after it read back
  // corrupt, as the readers' error advises). Rolling back to "the last commit" would then delete every
  // chunk file; the map is rebuilt from them instead, the newest whole file of each chunk.
  if (std::error_code ec; resume && fs::exists(fs::symlink_status(folder / "manifest.txt", ec)) &&
                          !fs::is_regular_file(folder / "manifest.txt", ec))
    fail((folder / "manifest.txt").string(), ": is not a regular file (a folder, FIFO, device or a link that leads to "
         "none); the map is left as it is");
  const bool manifest_lost = resume && !fs::exists(folder / "manifest.txt") && fs::exists(folder / "keyframes.txt");
  std::optional<double> rebuilt_far_level;  // the lost manifest's distance, as the run state kept it
  if (manifest_lost) {
    ChunkStoreConfig rebuild = store_config;
    rebuild.adopt_uncommitted = true;  // on this open only: the session's own files roll back as ever
    const LostMapState lost = take_map_geometry(folder / "run_state.json", rebuild);
    rebuilt_far_level = lost.far_level_distance;
    // Checked before the rebuild, which writes a manifest: the refused folder must stay as it was found.
    if (lost.keyframes_saw_chunks && !holds_chunk_files(folder / "chunks"))
      fail(folder.string(), ": manifest.txt and every chunk file are gone, but the keyframes in run_state.json saw "
           "chunks: the map's Gaussians are lost, and --resume would go on from an empty map. Restore chunks/ and "
           "manifest.txt, or map again without --resume into a new folder");
    const ChunkStore rebuilt(folder, rebuild);
    log::warn(folder.string(), ": manifest.txt is missing; rebuilt it from ", rebuilt.size(), " chunk files, chunks of ",
              rebuilt.chunk_size(), " m (chunks saved after the last checkpoint, if a crash left any, are kept too)");
  }
  store_ = std::make_unique<ChunkStore>(folder, store_config);
  if (resume) {
    recover_checkpoint_files();
    // A committed checkpoint names its keyframe list and run state; resuming without them would map
    // the frames again on top of the map (from frame 0, or with no keyframes).
    if (checkpoint_seq_ > 0)
      for (const char* name : {"keyframes.txt", "run_state.json"})
        if (!fs::exists(folder / name))
          fail(folder.string(), ": checkpoint ", checkpoint_seq_, " of this map has no ", name,
               ", so --resume cannot tell where the run stopped; the map is left as it is");
  }
  backend_ =
      make_optim_backend(device_, pool_capacity(config_.residency), store_->sh_degree(), config_.raster,
                         size_t(config_.mapper.gpu_keyframe_cache_mb) << 20,
                         config_.selector.max_candidates > 0 ? config_.selector.max_candidates : SIZE_MAX);
  ResidencyConfig rc = config_.residency;
  // In-core comparison: nothing may leave memory before the run stops once the map passes the
  // budget, so eviction starts only at the pool's full capacity (which the stop never reaches:
  // one keyframe adds far less than the headroom).
  if (config_.mapper.in_core_only) rc.budget_gaussians = pool_capacity(config_.residency);
  // Closing without a checkpoint (an error ended the run) must leave the folder at the last one:
  // writing the map of now would pair it with an older keyframe list.
  rc.flush_on_close = false;
  residency_ = std::make_unique<Residency>(*store_, backend_->pool(), rc);
  // The map's chunks have the levels its own far-level distance chose (store/chunk_levels.hpp).
  if (rebuilt_far_level) record_far_level_distance(*store_, *rebuilt_far_level);
  const double far_level = settle_far_level_distance(*store_, config_.culling.far_level_distance);
  if (far_level != config_.culling.far_level_distance)
    log::info("culling.far_level_distance ", config_.culling.far_level_distance, ": the map in ", folder.string(),
              " was made with ", far_level, far_level > 0 ? " m" : " (one level)", ", which it keeps");
  config_.culling.far_level_distance = far_level;
  if (manifest_lost) store_->commit();  // the rebuilt manifest names the distance before anyone reads it
  culler_ = std::make_unique<FrustumCuller>(store_->chunk_size(), config_.culling);
  if (resume && fs::exists(folder / "run_state.json")) {
    const fs::path file = folder / "run_state.json";
    resumed_state_ = read_json_file(file);
    validate_run_state(resumed_state_, file);
    require_same_geometry(resumed_state_, file, *store_);
    iterations_ = resumed_state_.value("iterations", uint64_t(0));
    steps_at_last_keyframe_ = steps_at_last_sampling_ = iterations_;
    try {
      if (resumed_state_.contains("keyframe_chunks")) {
        keyframe_chunks_ = KeyframeChunkIndex::from_json(resumed_state_["keyframe_chunks"]);
        resumed_state_["keyframe_chunks"] = true;  // its tree is ~30 MB after a 10 km drive: not kept
      }
    } catch (const std::exception& e) {  // a JSON type error, or the index's own Error
      fail(file.string(), ": 'keyframe_chunks' is damaged (", e.what(), ")");
    }
    if (resumed_state_.contains("rng")) {
      std::istringstream s(resumed_state_["rng"].get<std::string>());
      s >> rng_;
      if (!s) fail(file.string(), ": 'rng' is not a saved random state");
    }
  }
  keyframe_store_ = std::make_unique<KeyframeStore>(folder / "keyframes", config_.keyframes);
  if (resume && fs::exists(folder / "keyframes.txt")) {
    keyframes_ = read_keyframe_records(folder / "keyframes.txt");
    require_whole_keyframe_list(resumed_state_, folder / "run_state.json", keyframes_, folder / "keyframes.txt");
    std::vector<uint64_t> known;
    for (const auto& k : keyframes_) {
      if (!keyframe_store_->contains(k.id))
        fail(folder.string(), ": keyframe ", k.id, " is listed in keyframes.txt but its images are missing");
      selector_.add(k.id, k.pose.t, k.uses, k.last_loss);
      known.push_back(k.id);
    }
    // Keyframes stored after the last checkpoint are dropped: their frames are processed again.
    for (uint64_t id : keyframe_store_->ids())
      if (std::find(known.begin(), known.end(), id) == known.end()) keyframe_store_->erase(id);
    update_training_window();
  }
  // A map made with a sky keeps it (and its training) whatever the settings say now.
  if (resume && fs::exists(folder / "sky.bin")) {
    backend_->set_sky(read_sky_file(folder / "sky.bin"), config_.sky.lr);
    sky_on_ = true;
  }
  keyframes_in_checkpoint_ = keyframes_.size();
  // A map saved before the index existed: a loop correction then visits every chunk.
  if (!keyframes_.empty() && !resumed_state_.contains("keyframe_chunks")) keyframe_chunks_.set_incomplete();
  if (store_->open_report().repaired())
    log::info("map ", folder.string(), ": repaired after an interrupted run (",
              store_->open_report().entries_adopted, " chunk files adopted, ",
              store_->open_report().entries_updated, " updated)");
}

Mapper::~Mapper() {
  // A checkpoint in flight uses the keyframe store, which goes before the residency.
  try {
    residency_->finish_checkpoint();
  } catch (const std::exception& e) {
    // While an error ends the run, its report is the one error: this failure mostly has the same
    // cause (a sticky keyframe-store error), and what it means for the folder is a warning.
    if (std::uncaught_exceptions() > 0)
      log::warn("mapper: the checkpoint in flight was not committed either (", e.what(), "); the previous one stands");
    else
      log::error("mapper: the checkpoint in flight failed: ", e.what());
  }
  remove_keyframes_after_checkpoint();
}

uint64_t Mapper::total_gaussians() const {
  uint64_t n = 0;
  for (const auto& kv : residency_->catalogue()) n += kv.second;
  return n;
}

std::vector<ChunkCount> Mapper::nearest_visible(const Camera& camera, const SE3& pose) {
  culler_->set_chunks_from(residency_->catalogue(), residency_->catalogue_version());
  return nearest_first(culler_->cull(camera, pose), *residency_, store_->chunk_size(), pose.t);
}

std::vector<ChunkId> Mapper::visible_chunks(const Camera& camera, const SE3& pose, std::vector<ChunkId>* left_out) {
  std::vector<ChunkId> out;
  uint64_t total = 0, needed = 0;
  for (const ChunkCount& c : nearest_visible(camera, pose)) {
    needed += c.count;
    if (total + c.count > residency_->budget()) {  // the farthest chunks give way
      if (left_out) left_out->push_back(c.id);
      continue;
    }
    total += c.count;
    out.push_back(c.id);
  }
  if (needed > residency_->budget()) note_view_over_budget(needed);
  return out;
}

void Mapper::note_view_over_budget(uint64_t needed) {
  ++views_over_budget_;
  if (worth_saying_again(needed, largest_view_))
    log::warn("the budget of ", residency_->budget(), " Gaussians is below what one view needs (", needed,
              " in its visible chunks): the farthest chunks are left out of its training steps (renders draw it "
              "in passes); a budget of at least ", needed, " (--budget) keeps whole views");
}

void Mapper::note_refused(uint32_t keyframe, ChunkId chunk, uint64_t gaussians, const PinResult& why) {
  refused_gaussians_ += gaussians;
  const uint64_t needed = why.budget + why.over_budget;
  // A budget this small refuses new Gaussians at every keyframe.
  if (worth_saying_again(needed, largest_refusal_))
    log::warn("keyframe ", keyframe, ": its ", gaussians, " new Gaussians in ", chunk_name(chunk),
              " do not fit the budget of ", why.budget, " Gaussians beside the chunk's ", needed - gaussians -
              why.pinned_gaussians, " and ", why.pinned_gaussians, " pinned ones, so they are left out of the map; "
              "a budget of at least ", needed, " (--budget) keeps them");
}

RenderOutput<float> Mapper::render(const Camera& camera, const SE3& pose) {
  const RenderCamera<float> rc = make_render_camera<float>(camera, pose);
  const auto draw = [&](const std::vector<ChunkId>& chunks, bool sky) {
    return with_pinned_slots(*residency_, chunks, slots_, "mapper", [&](const std::vector<uint32_t>& slots) {
      return backend_->render(slots, rc, sky);
    });
  };
  const std::vector<ChunkCount> near = nearest_visible(camera, pose);
  uint64_t needed = 0;
  for (const ChunkCount& c : near) needed += c.count;
  if (needed > residency_->budget()) note_view_over_budget(needed);
  // More than the budget holds: the whole view in passes of chunks that fit, nearest first, each
  // pass's chunks made resident in turn. Left out, the far street rendered as sky, and a map under
  // a budget below one view scored as if it lacked it.
  const BudgetGroups groups = split_by_budget(near, residency_->budget());
  if (groups.groups.size() <= 1) return draw(groups.groups.empty() ? std::vector<ChunkId>() : groups.groups[0], true);
  ++renders_in_passes_;
  RenderOutput<float> out = render_front_to_back(
      groups.groups, [&](const std::vector<ChunkId>& chunks) { return draw(chunks, false); }, config_.raster.background);
  if (const std::optional<SkyTexture> sky = backend_->sky()) {
    ImageF sky_px;
    sky_colours(*sky, rc, sky_px);
    compose_sky(sky_px, out.alpha, out.rgb);
  }
  return out;
}

// New Gaussians for keyframe `id` where its image has detail the render of the map lacks.
SampleStats Mapper::sample_view(uint32_t id, const Image8& color, const ImageF& depth, const Camera& camera,
                                const SE3& pose, uint64_t cap, const std::vector<Eigen::Vector3d>* seeds,
                                const std::vector<ChunkId>* not_sampled, const std::vector<ChunkId>* core) {
  using clock = std::chrono::steady_clock;
  SampleStats stats;
  const ImageF target = to_rgb_float(color);
  std::vector<ChunkId> left_out;
  std::vector<ChunkId> shown = visible_chunks(camera, pose, &left_out);
  // Beyond the view's core only what is resident is drawn (selector.core_share), and so sampled.
  if (core && !residency_->all_resident())
    std::erase_if(shown, [&](ChunkId c) {
      return !residency_->is_resident(c) && !std::binary_search(core->begin(), core->end(), c);
    });
  // Computed by the backend, so on the GPU only the one-channel map comes back to the host.
  const auto t1 = clock::now();
  const ImageF prob = with_pinned_slots(*residency_, shown, slots_, "mapper", [&](const std::vector<uint32_t>& slots) {
    return backend_->sampling_probability(slots, make_render_camera<float>(camera, pose), config_.sampler, target);
  });
  keyframe_times_.render_ms += ms_since(t1);
  const auto t2 = clock::now();
  // What the render lacks only because chunks stayed on disk is not sampled again; nor is any
  // other chunk of the map the render did not draw (beyond the far plane).
  std::unordered_set<ChunkId> exclude, established;
  for (const auto& [chunk, count] : residency_->catalogue())
    if (count > 0) exclude.insert(chunk);
  for (ChunkId chunk : shown)
    if (exclude.erase(chunk)) established.insert(chunk);
  if (not_sampled) exclude.insert(not_sampled->begin(), not_sampled->end());
  const bool pooling = config_.sampler.stray_wait_keyframes > 0;
  std::vector<ChunkBatch> strays;
  RefineDepths refine;
  if (refine_range_ > 0)
    refine = [&](std::vector<PixelDepth>& pixels) {
      refine_sampled_depths(camera, pose, id, keyframes_, *keyframe_store_, config_.multiview, refine_range_,
                            device_ == "cuda", pixels, refine_totals_);
    };
  // With the pool, the cap is applied below to the sampler's picks and the pool's new chunks together.
  auto batches = sample_gaussians(config_.sampler, target, depth, prob, camera, pose, grid(), id,
                                  uint32_t(iterations_), rng_, &stats, &exclude, pooling ? 0 : cap, seeds, &refine,
                                  &established, pooling ? &strays : nullptr);
  keyframe_times_.sample_ms += ms_since(t2);
  const auto t3 = clock::now();
  if (pooling) {
    // A chunk exists once the map holds it or this keyframe's picks make it.
    std::unordered_set<ChunkId> made;
    for (const ChunkBatch& b : batches) made.insert(b.id);
    const auto exists = [&](ChunkId c) {
      const auto it = residency_->catalogue().find(c);
      return made.count(c) || (it != residency_->catalogue().end() && it->second > 0);
    };
    auto released = stray_pool_.add(id, std::move(strays), config_.sampler.min_per_chunk(color.pixels(), store_->chunk_size()),
                                    config_.sampler.stray_wait_keyframes, uint32_t(iterations_), exists);
    for (const ChunkBatch& b : released) stats.released_strays += b.block.size();
    const uint64_t limit = config_.sampler.new_gaussian_limit(cap);
    batches.insert(batches.end(), std::make_move_iterator(released.begin()), std::make_move_iterator(released.end()));
    // Both lose the same share, as the sampler's own cap thins every chunk alike.
    if (limit) stats.capped += keep_random_subset(batches, limit, rng_);
    stats.kept = 0;
    for (const ChunkBatch& b : batches) stats.kept += b.block.size();
    stats.chunks = batches.size();
  }
  std::vector<ChunkAddition> additions;
  for (const ChunkBatch& b : batches) additions.push_back({b.id, &b.block});
  const std::vector<PinResult> added = residency_->add_many(additions);
  for (size_t i = 0; i < batches.size(); ++i) {
    const ChunkBatch& b = batches[i];
    if (!added[i].ok) {
      stats.kept -= b.block.size();
      note_refused(id, b.id, b.block.size(), added[i]);
    } else {
      keyframe_chunks_.add(id, b.id);
    }
  }
  sampled_total_ += stats.kept;
  strays_held_back_ += stats.dropped_small_chunks;
  strays_released_ += stats.released_strays;
  keyframe_times_.add_ms += ms_since(t3);
  return stats;
}

SampleStats Mapper::add_keyframe(uint64_t frame, double stamp, const Image8& color,
                                 const std::optional<ImageF>& depth, const Camera& camera, const SE3& pose,
                                 const std::vector<Eigen::Vector3d>* seeds) {
  camera.validate(cat("keyframe of frame ", frame));
  if (depth && !depth->same_size(color))
    fail("mapper: frame ", frame, ": depth ", depth->width(), "x", depth->height(),
         " does not match the image ", color.width(), "x", color.height());
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  const uint32_t id = keyframes_.empty() ? 0 : keyframes_.back().id + 1;
  if (config_.sky.enabled && !sky_on_) {
    // Its pole is the first keyframe's up: the camera's -y, cameras being held level.
    const Eigen::Matrix3d rot = pose.rotation();
    double R[9];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R[3 * r + c] = rot(r, c);
    backend_->set_sky(make_sky(config_.sky, R), config_.sky.lr);
    sky_on_ = true;
  }
  keyframe_store_->put(id, KeyframeImages{color, depth ? *depth : ImageF()});
  SampleStats stats;
  if (depth && std::none_of(depth->data(), depth->data() + depth->pixels(),
                            [](float d) { return d > 0 && std::isfinite(d); })) {
    // Said once: an empty map with no word of why was what a too small image for the stereo
    // search range gave before the matcher covered the whole width.
    if (keyframes_without_depth_++ == 0)
      log::warn("frame ", frame, ": its depth has no valid pixel, so nothing is sampled from it (a depth file "
                "without data, or stereo images that do not match); report.json counts such keyframes "
                "(keyframes_without_depth)");
  }
  if (!config_.sampler.map_point_seeds || (seeds && seeds->empty())) seeds = nullptr;
  // What another view showed on twice the blocks (selector.best_view_share) is not sampled from this one:
  // without a budget, views that glimpsed a street from afar had put a haze over it (2 km street at 310x94:
  // 8.8-17.2 dB held-out on a stretch no later view came within 40 m of; bench/README.md, issue 19).
  std::optional<ViewCoverage> coverage;
  std::vector<ChunkId> not_sampled;
  std::vector<ChunkId> core;
  const bool cores = config_.selector.core_share < 1;
  if ((config_.selector.best_view_share > 0 || cores) && depth) {
    coverage.emplace(*depth, camera, pose, grid(), config_.sampler.fill_depth);
    not_sampled = chunks_sampled_better(id, *coverage);
    if (cores) core = coverage->core(config_.selector.core_share);
  }
  if (depth || seeds) {
    // Seeds need no depth map: without one (a keyframe whose depth comes later) only they are taken.
    const ImageF none = depth ? ImageF() : ImageF(color.width(), color.height(), 1, 0.0f);
    stats = sample_view(id, color, depth ? *depth : none, camera, pose, new_gaussian_cap(color), seeds,
                        &not_sampled, coverage && cores ? &core : nullptr);
  }
  steps_at_last_keyframe_ = steps_at_last_sampling_ = iterations_;
  KeyframeRecord rec;
  rec.id = id;
  rec.frame = frame;
  rec.stamp = stamp;
  rec.camera = camera;
  rec.pose = pose;
  selector_.add(id, pose.t);
  give_back_picks_ahead();  // they predate this keyframe (and may lie in the cell it just left)
  rec.uses = selector_.usage(id).uses;
  keyframes_.push_back(rec);
  if (coverage) {
    best_views_.note(id, *coverage);
    coverage_.insert_or_assign(id, std::move(*coverage));
    if (cores) core_chunks_.insert_or_assign(id, std::move(core));
  }
  update_training_window();
  ++keyframe_times_.keyframes;
  keyframe_times_.total_ms += ms_since(t0);
  return stats;
}

void Mapper::set_depth_refinement(double inv_range) {
  if (!(inv_range >= 0) || !std::isfinite(inv_range))
    fail("mapper: depth refinement range ", inv_range, " (0: off, else a positive inverse depth in 1/m)");
  refine_range_ = inv_range;
}

KeyframeRecord& Mapper::keyframe_of_frame(uint64_t frame) {
  for (auto it = keyframes_.rbegin(); it != keyframes_.rend(); ++it)
    if (it->frame == frame) return *it;
  fail("mapper: no keyframe of frame ", frame, " to give depth to");
}

SampleStats Mapper::add_late_depth(uint64_t frame, const ImageF& depth) {
  const KeyframeRecord* kf = &keyframe_of_frame(frame);
  const std::shared_ptr<const KeyframeImages> images = keyframe_store_->get(kf->id);
  if (!depth.same_size(images->color) || depth.channels() != 1)
    fail("mapper: frame ", frame, ": depth ", depth.width(), "x", depth.height(), " does not match the image ",
         images->color.width(), "x", images->color.height());
  const auto t0 = std::chrono::steady_clock::now();
  // Capped as a keyframe arriving now would be, without counting as one for the cap's average.
  const double rate = config_.sampler.new_per_step;
  const uint64_t cap =
      rate > 0 && steps_per_keyframe_ >= 0
          ? uint64_t(rate * (double(images->color.pixels()) / 1e5) * std::max(steps_per_keyframe_, 1.0))
          : 0;
  const SampleStats stats = sample_view(kf->id, images->color, depth, kf->camera, kf->pose, cap);
  keyframe_times_.total_ms += ms_since(t0);
  return stats;
}

void Mapper::resample(const KeyframeRecord& kf) {
  const std::shared_ptr<const KeyframeImages> images = keyframe_store_->get(kf.id);
  if (images->depth.empty()) return;
  // As many as the keyframe cap allows for this many steps.
  const double rate = config_.sampler.new_per_step;
  const uint64_t cap = rate > 0 ? std::max<uint64_t>(config_.sampler.min_per_chunk(images->color.pixels(), store_->chunk_size()),
                                                     uint64_t(rate * (double(images->color.pixels()) / 1e5) *
                                                              double(config_.sampler.resample_every)))
                                : 0;
  sample_view(kf.id, images->color, images->depth, kf.camera, kf.pose, cap, nullptr,
              loads_cores() ? &core_chunks_of(kf) : nullptr);
}

void Mapper::set_raster_segment_entries(int entries) {
  RasterConfig c = config_.raster;
  c.segment_entries = entries;
  c.validate();
  config_.raster = c;
  backend_->set_raster_config(c);
}

double Mapper::rate_steps_per_keyframe() const {
  // Under fixed pacing every keyframe gets the configured steps; in real time the steps the recent
  // keyframes got (none measured yet: the rates as given).
  return config_.mapper.pacing == "fixed" ? double(config_.mapper.iterations_per_keyframe) : steps_per_keyframe_;
}

AdamConfig Mapper::step_rates(const Camera& camera) const {
  return config_.adam.for_image(camera.width, camera.height).for_steps(rate_steps_per_keyframe());
}

uint64_t Mapper::new_gaussian_cap(const Image8& image) {
  if (keyframes_.empty()) return 0;  // the first keyframe fills an empty map
  const double steps = double(iterations_ - steps_at_last_keyframe_);
  steps_per_keyframe_ = steps_per_keyframe_ < 0 ? steps : 0.75 * steps_per_keyframe_ + 0.25 * steps;
  const double rate = config_.sampler.new_per_step;
  if (!(rate > 0)) return 0;
  const double cap = rate * (double(image.pixels()) / 1e5) * std::max(steps_per_keyframe_, 1.0);
  return std::max<uint64_t>(config_.sampler.min_per_chunk(image.pixels(), store_->chunk_size()), uint64_t(cap));
}

double Mapper::optimiser_io_wait_ms() const {
  return residency_->stats().optimiser_wait_ms() + keyframe_store_->counters().snapshot().optimiser_wait_ms();
}

const KeyframeRecord* Mapper::find_keyframe(uint32_t id) const {
  // Ids are handed out in order from 0, so the id is the index unless the list was edited.
  if (id < keyframes_.size() && keyframes_[id].id == id) return &keyframes_[id];
  const auto it = std::find_if(keyframes_.begin(), keyframes_.end(), [&](const auto& k) { return k.id == id; });
  return it == keyframes_.end() ? nullptr : &*it;
}

}  // namespace chungs
