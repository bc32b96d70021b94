// Mapper: keyframes in, an optimised chunked Gaussian map out. Each new keyframe is sampled into
// new Gaussians (Sampler); each optimisation step picks a keyframe (KeyframeSelector), culls the
// chunks it sees, makes them resident within the budget (Residency), renders them from the pool's
// slots, and applies the loss gradient with sparse Adam, marking the chunks modified; every few
// steps nearly transparent or oversized Gaussians are pruned. Keyframe images live in the
// KeyframeStore. checkpoint() makes the folder a complete map that `resume` reopens.
// The pool, the renderer and the optimiser live in an OptimBackend (config.mapper.device: host or
// GPU). Not thread-safe: one thread drives it.
#pragma once
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "chungs/config/config.hpp"
#include "chungs/mapping/keyframe_selector.hpp"
#include "chungs/mapping/loop_corrector.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/mapping/sample_refine.hpp"
#include "chungs/mapping/sampler.hpp"
#include "chungs/mapping/stray_pool.hpp"
#include "chungs/mapping/best_views.hpp"
#include "chungs/mapping/view_coverage.hpp"
#include "chungs/residency/budget_groups.hpp"
#include "chungs/residency/frustum_culler.hpp"
#include "chungs/residency/residency.hpp"
#include "chungs/store/keyframe_store.hpp"

namespace chungs {

struct RefinementGroup;

struct StepStats {
  uint32_t keyframe = 0;
  double loss = 0;
  size_t rendered = 0;  // Gaussians in the visible chunks
  size_t chunks = 0;
  size_t pruned = 0;
  bool revisit = false;  // a keyframe revisited far behind the latest (selector.revisit_share)
};

class Mapper {
 public:
  // Opens or creates the map folder. With resume, keyframes, selector state and run state are read
  // back from the last checkpoint; without it, a folder that already holds a map is refused.
  Mapper(const std::filesystem::path& folder, const Config& config, bool resume);
  ~Mapper();
  Mapper(const Mapper&) = delete;
  Mapper& operator=(const Mapper&) = delete;

  // Stores the keyframe, renders the map from its pose, samples new Gaussians where the render
  // lacks the image's detail. color: 1 or 3 channels; depth: metres (0 invalid), or none.
  // seeds: world points (the tracker's map points first seen by this keyframe) that become Gaussians
  // of it as well, when sampler.map_point_seeds is on (sample_gaussians).
  SampleStats add_keyframe(uint64_t frame, double stamp, const Image8& color,
                           const std::optional<ImageF>& depth, const Camera& camera, const SE3& pose,
                           const std::vector<Eigen::Vector3d>* seeds = nullptr);
  // Samples the keyframe of `frame`, added earlier without depth, at a depth known only now (one
  // camera: the first keyframe has no earlier one to sweep against). The depth serves this sampling
  // only; the keyframe keeps being trained without a depth target. Throws Error for an unknown frame
  // or a depth of another size.
  SampleStats add_late_depth(uint64_t frame, const ImageF& depth);
  // A later depth for the guessed pixels of frame's keyframe (negative in its stored depth: one
  // camera's fill). Where `fresh` is positive at a guess, the stored depth takes it (a depth-loss
  // target from now on), and the keyframe's Gaussians at such a pixel, unless the optimiser has moved
  // them off their guess by more than a quarter, slide along the keyframe's ray to the new depth,
  // their size scaled alike. Returns the pixels replaced. Throws Error for an unknown frame or a depth
  // of another size.
  size_t redepth(uint64_t frame, const ImageF& fresh);
  struct RedepthTotals {
    uint64_t keyframes = 0, pixels = 0, gaussians_moved = 0;
  };
  const RedepthTotals& redepth_totals() const { return redepth_totals_; }
  // Measured depth (RGB-D, stereo): from now on the depths of the pixels a sampling draws are polished
  // by the plane sweep against earlier keyframes over their inverse depth -+ inv_range (1/m; 0: off;
  // mapping/sample_refine.hpp). The run sets it from config.multiview.refine and the depth's kind.
  void set_depth_refinement(double inv_range);
  double depth_refinement() const { return refine_range_; }
  const SampleRefineTotals& refine_totals() const { return refine_totals_; }
  StepStats step();  // one optimisation step; throws when there is no keyframe yet
  // The refinement after the last frame: `steps` steps spread over every keyframe, each on its whole
  // view and every pixel of it (no best-view masks: every view of a place is trained, as without a
  // budget), in groups of keyframes whose views fit 0.8 of the budget, visited in mapper.refinement_rounds
  // rounds, in a random order within a group (mapping/refinement_plan.hpp). `after_step` runs after each,
  // given its keyframe; when `stop` returns true before a step, the refinement ends there. Throws when
  // there is no keyframe and steps > 0.
  struct RefineStats {
    uint64_t steps = 0, groups = 0;
  };
  RefineStats refine(uint64_t steps, const std::function<void(uint32_t keyframe)>& after_step = {},
                     const std::function<bool()>& stop = {});
  // mapper.final_iterations resolved for this map: MapperConfig::refinement_steps of its keyframes and of
  // the groups the refinement would train in turn (1 when the views fit the budget together; more the
  // smaller the budget), which the automatic steps grow with. Culls every keyframe's view when automatic.
  uint64_t refinement_steps();
  // Renders the map from any pose (pins the visible chunks meanwhile). A copy of the output.
  RenderOutput<float> render(const Camera& camera, const SE3& pose);

  // Loop closure or bundle adjustment: keyframes take the new camera-to-world poses (mapper keyframe
  // id -> pose) and the Gaussians they created move with them, between chunks where needed (see
  // loop_corrector.hpp). The Gaussians of the `junction` keyframes get the sampler's initial
  // opacity and fresh Adam state, then `refine_iterations` steps train on the junction keyframes in
  // turn (on the selector's picks when the junction is empty). Call checkpoint() afterwards: until
  // then the folder's keyframe list still holds the old poses.
  PoseCorrectionStats correct_poses(const std::vector<std::pair<uint32_t, SE3>>& new_poses,
                                    const std::vector<uint32_t>& junction, int refine_iterations);
  // false: corrections visit one chunk at a time even when the chunks would fit (tests that path).
  void set_loop_batch_allowed(bool allowed) { loop_batch_allowed_ = allowed; }

  // Writes every modified chunk, the manifest, the keyframe list and `run_state`, followed by the
  // members in `more` (JSON text, ",\"key\":value" each: what grows with the run, kept out of JSON
  // trees; see common/text_pieces.hpp). behind: the map as it is now is written while training goes
  // on (Residency::begin_checkpoint); it is the resume point once committed, and the next
  // checkpoint (or the destructor) waits for it.
  void checkpoint(const nlohmann::json& run_state, bool behind = false, TextPieces more = {});
  const nlohmann::json& resumed_state() const { return resumed_state_; }

  const std::vector<KeyframeRecord>& keyframes() const { return keyframes_; }
  const KeyframeRecord* find_keyframe(uint32_t id) const;  // null when unknown
  uint64_t iterations() const { return iterations_; }
  uint64_t total_gaussians() const;
  size_t resident_gaussians() const { return residency_->resident_gaussians(); }
  size_t peak_resident_gaussians() const { return residency_->peak_resident_gaussians(); }
  size_t budget() const { return residency_->budget(); }
  size_t chunk_count() const { return residency_->catalogue().size(); }
  IoStats io_stats() const { return residency_->stats(); }
  IoStats keyframe_io_stats() const { return keyframe_store_->counters().snapshot(); }
  // Host memory for the chunks in flight (residency.hpp, in_flight_blocks). A run whose map will
  // outgrow the budget makes it resident at the start, so host RSS does not move when queues fill.
  HostBlockPool& in_flight_blocks() { return residency_->in_flight_blocks(); }
  const HostBlockPool& in_flight_blocks() const { return residency_->in_flight_blocks(); }
  // Time the optimiser thread was blocked by I/O: chunk loads it waited for, checkpoints, and
  // keyframe reads it waited for (keyframe writes run behind; their flush is part of a checkpoint).
  double optimiser_io_wait_ms() const;
  uint64_t pruned_total() const { return pruned_total_; }
  uint64_t sampled_total() const { return sampled_total_; }  // Gaussians the sampler added (this process)
  // Picks the stray-chunk rule held back, those later made into chunks, those dropped (this process).
  uint64_t strays_held_back() const { return strays_held_back_; }
  uint64_t strays_released() const { return strays_released_; }
  uint64_t strays_forgotten() const { return stray_pool_.forgotten(); }
  // Steps since the latest keyframe was added.
  uint64_t steps_since_keyframe() const { return iterations_ - steps_at_last_keyframe_; }
  // The factor on opacity, colour and scale rates for the steps keyframes get now (1: as given).
  double rate_steps_factor() const { return config_.adam.steps_factor(rate_steps_per_keyframe()); }
  // Keyframes given a depth map without one valid pixel (nothing could be sampled from them).
  uint64_t keyframes_without_depth() const { return keyframes_without_depth_; }
  uint64_t views_over_budget() const { return views_over_budget_; }  // views whose chunks exceed the budget
  uint64_t renders_in_passes() const { return renders_in_passes_; }  // render() calls drawn in passes
  uint64_t largest_view() const { return largest_view_; }  // Gaussians of the largest such view
  // New Gaussians left out because their chunk could not hold them under the budget (this process),
  // and the least budget that would have held the largest such chunk.
  uint64_t refused_gaussians() const { return refused_gaussians_; }
  uint64_t largest_refusal() const { return largest_refusal_; }
  // Where the optimiser thread's step time went (sums; the backend's includes keyframe loads it
  // asked for, and on the GPU the wait for the device).
  // chunks_ms = cull_ms + pin_ms + the slot list; pick_ms: drawing the next step's keyframe, culling
  // its view and queueing its reads (step() only); bookkeeping_ms: after the backend (dirty marks,
  // pruned slots back to their chunks, unpinning, the selector's loss).
  struct StepTimes {
    uint64_t steps = 0, keyframe_loads = 0;
    double total_ms = 0, chunks_ms = 0, keyframe_load_ms = 0, backend_ms = 0;
    double pick_ms = 0, cull_ms = 0, pin_ms = 0, bookkeeping_ms = 0;
    double slots_ms = 0;  // of chunks_ms: the slot list written
    double prune_ms = 0;  // of bookkeeping_ms: pruned Gaussians leaving their chunks
    StepTimes operator-(const StepTimes& b) const;  // the steps between two snapshots (b before)
  };
  const StepTimes& step_times() const { return step_times_; }
  // The backend's per-phase timings (optim_backend.hpp), for benchmarks: on costs a device wait a step.
  void set_step_profiling(bool on) { backend_->set_profiling(on); }
  // Only the GPU's segment_entries, for benchmarks: the rest shapes the map and stays as configured.
  void set_raster_segment_entries(int entries);
  const StepPhaseTimes& step_phase_times() const { return backend_->phase_times(); }
  // Where add_keyframe's time went (sums): the sampler's render and acceptance map, drawing the new
  // Gaussians, handing them to residency.
  struct KeyframeTimes {
    uint64_t keyframes = 0;
    double total_ms = 0, render_ms = 0, sample_ms = 0, add_ms = 0;
  };
  const KeyframeTimes& keyframe_times() const { return keyframe_times_; }
  // How often the budget narrowed training to a window, and how wide the windows were.
  struct WindowStats {
    uint64_t updates = 0, narrowed = 0;
    // Steps on a keyframe outside the window, on the resident part of its view; and picks outside
    // it whose resident part covered too little, trained on a window keyframe instead.
    uint64_t partial_steps = 0, partial_too_small = 0;
    // Steps on a window keyframe whose view needs more than the budget, scored without the pixels
    // that its left-out (farthest) chunks would have drawn.
    uint64_t trimmed_steps = 0;
    // Steps that left out chunks their view shows far smaller than a view gone from the window did.
    uint64_t best_view_steps = 0;
    // Steps on a window keyframe that left out chunks beyond its core that were not resident.
    uint64_t beyond_core_steps = 0;
    // Steps and bursts on keyframes revisited far behind the latest (selector.revisit_share).
    uint64_t revisit_steps = 0, revisit_bursts = 0;
    double keyframes = 0, cell_keyframes = 0, reach_m = 0;  // sums over the narrowed updates
  };
  const WindowStats& window_stats() const { return window_stats_; }
  const std::filesystem::path& folder() const { return folder_; }
  const Config& config() const { return config_; }
  const std::string& device() const { return device_; }  // "cpu" or "cuda"
  std::optional<DeviceMemory> device_memory() const { return backend_->device_memory(); }

 private:
  // Visible chunks of a view, nearest first, trimmed so that they fit the budget; the ones trimmed
  // go to left_out.
  std::vector<ChunkId> visible_chunks(const Camera& camera, const SE3& pose, std::vector<ChunkId>* left_out = nullptr);
  // Every visible chunk that holds Gaussians, nearest first, with its count.
  std::vector<ChunkCount> nearest_visible(const Camera& camera, const SE3& pose);
  // The refinement's groups for `steps` steps (refinement_plan.hpp), from every keyframe's view.
  std::vector<RefinementGroup> plan_refinement_groups(uint64_t steps);
  void note_view_over_budget(uint64_t needed);  // warns when a view needs more than the budget
  // Counts new Gaussians the residency refused (their chunk cannot hold them under the budget) and warns.
  void note_refused(uint32_t keyframe, ChunkId chunk, uint64_t gaussians, const PinResult& why);
  // New Gaussians a keyframe may add: what the optimiser trained per keyframe lately (see
  // SamplerConfig::new_per_step); 0 for no cap.
  uint64_t new_gaussian_cap(const Image8& image);
  // The steps per keyframe that the optimiser's rates follow (AdamConfig::reference_steps), and the
  // rates of a step on a view from that camera.
  double rate_steps_per_keyframe() const;
  AdamConfig step_rates(const Camera& camera) const;
  bool refining_ = false;  // inside refine(): steps score every pixel of their view
  void resample(const KeyframeRecord& kf);
  SampleStats sample_view(uint32_t id, const Image8& color, const ImageF& depth, const Camera& camera,
                          const SE3& pose, uint64_t cap, const std::vector<Eigen::Vector3d>* seeds = nullptr,
                          const std::vector<ChunkId>* not_sampled = nullptr,
                          const std::vector<ChunkId>* core = nullptr);
  // One optimisation step on the given keyframe: on its whole view (loading what it needs) when it is
  // in the training window or `whole_view`, else on the resident part (view_coverage.hpp).
  // `revisit`: a keyframe revisited behind the window (selector.revisit_share), trained as a window keyframe.
  StepStats step_keyframe(uint32_t keyframe, bool whole_view = false, bool revisit = false);
  // Where the keyframe's pixels see surfaces, by chunk (built on first use while it is in the cell).
  const ViewCoverage& coverage_of(const KeyframeRecord& kf);
  // Narrows the selector's candidates to the keyframes whose views fit the budget together
  // (training_window.hpp); after every change of the keyframes or their poses.
  void update_training_window();
  // Where a view's new Gaussians and coverage blocks go: the map's chunks at their levels.
  ChunkGrid grid() const { return {store_->chunk_size(), config_.culling.far_level_distance}; }
  std::filesystem::path folder_;
  Config config_;
  std::unique_ptr<ChunkStore> store_;
  std::string device_;
  std::unique_ptr<OptimBackend> backend_;  // owns the pool: declared before residency_, outlives it
  std::unique_ptr<Residency> residency_;
  std::unique_ptr<FrustumCuller> culler_;
  std::unique_ptr<KeyframeStore> keyframe_store_;
  KeyframeSelector selector_;
  std::vector<KeyframeRecord> keyframes_;
  std::mt19937_64 rng_;
  uint64_t iterations_ = 0, pruned_total_ = 0, sampled_total_ = 0;
  uint64_t strays_held_back_ = 0, strays_released_ = 0;
  uint64_t steps_at_last_keyframe_ = 0, steps_at_last_sampling_ = 0;
  uint64_t views_over_budget_ = 0, largest_view_ = 0, keyframes_without_depth_ = 0, renders_in_passes_ = 0;
  uint64_t refused_gaussians_ = 0, largest_refusal_ = 0;
  WindowStats window_stats_;
  StepTimes step_times_;
  KeyframeTimes keyframe_times_;
  double steps_per_keyframe_ = -1;  // smoothed steps the keyframes got (-1: none measured yet)
  nlohmann::json resumed_state_;
  std::vector<uint32_t> slots_, to_prune_;
  KeyframeRecord* mutable_keyframe(uint32_t id) {
    return const_cast<KeyframeRecord*>(std::as_const(*this).find_keyframe(id));
  }
  KeyframeRecord& keyframe_of_frame(uint64_t frame);  // the newest of that frame; throws Error when none
  uint64_t checkpoint_seq_ = 0;  // the last committed checkpoint (see recover_checkpoint_files)
  // Keyframes the newest checkpoint begun (or the one resumed) names: those after them are removed
  // on close, since no committed checkpoint can name them.
  size_t keyframes_in_checkpoint_ = 0;
  void recover_checkpoint_files();
  void remove_keyframes_after_checkpoint();
  // The selector's picks for the next steps (mapper.read_ahead_steps), each with the chunks its view
  // loads, which are read ahead in the background with its images.
  struct PickAhead {
    uint32_t keyframe;
    std::vector<ChunkId> chunks;
    bool revisit = false;  // drawn by revisit_pick, not the selector
  };
  std::deque<PickAhead> picks_ahead_;
  void draw_pick_ahead();
  // The next pick of a revisit burst (selector.revisit_share), or none: revisit_credit_ gains the share at
  // every pick and a burst starts once it holds a whole burst; revisit_group_ is the burst's keyframes.
  std::optional<uint32_t> revisit_pick();
  double revisit_credit_ = 0;
  int revisit_left_ = 0;
  std::vector<uint32_t> revisit_group_;
  void give_back_picks_ahead();
  uint32_t window_pick_ahead();  // the first window pick drawn ahead (taken from the list), or a new one
  KeyframeChunkIndex keyframe_chunks_;  // saved in run_state at each checkpoint
  RedepthTotals redepth_totals_;
  StrayPool stray_pool_;  // not saved: a resumed run starts it empty
  std::unordered_map<uint32_t, std::vector<ChunkId>> view_chunks_;  // chunks of the cell's views
  std::unordered_map<uint32_t, ViewCoverage> coverage_;             // of the cell's views (partial steps)
  BestViews best_views_;  // of the map's chunks (selector.best_view_share)
  std::unordered_map<uint32_t, std::vector<ChunkId>> core_chunks_;  // of the cell's views, sorted (core_share)
  const std::vector<ChunkId>& core_chunks_of(const KeyframeRecord& kf);
  const std::vector<ChunkId>* known_core(const KeyframeRecord& kf);  // null: its coverage is not built
  // Views load only their cores (selector.core_share) while the map exceeds the budget.
  bool loads_cores() const { return config_.selector.core_share < 1 && !residency_->all_resident(); }
  // The chunks of the view that a step leaves out under best_view_share (empty: none), sorted.
  std::vector<ChunkId> chunks_shown_better(uint32_t keyframe, const ViewCoverage& coverage) const;
  // The chunks of the view that the sampler leaves out under best_view_share, window or not, sorted.
  std::vector<ChunkId> chunks_sampled_better(uint32_t keyframe, const ViewCoverage& coverage) const;
  bool loop_batch_allowed_ = true;
  bool sky_on_ = false;  // the backend holds a sky (render/sky.hpp), saved with each checkpoint
  uint64_t nonfinite_losses_ = 0;  // steps whose loss was NaN or infinite (warned once)
  double refine_range_ = 0;        // set_depth_refinement
  SampleRefineTotals refine_totals_;
};

}  // namespace chungs
