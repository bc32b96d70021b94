// KeyframeSelector: which keyframe the next optimisation step trains on. Only keyframes near the
// latest one are candidates, so training stays near the car and the chunks it needs stay resident (no
// thrashing between distant places): by default those within cell_size / 2 of it (around_latest); the paper's
// rule, a coarse grid of 200 m cells and the latest keyframe's cell, is kept as a setting.
// Within the cell, CaRtGS's usage rule: a new keyframe has `new_uses` remaining uses; when no
// candidate has any left, every candidate gets +1 and the top quarter by last loss another +1; the
// pick is random, weighted by remaining uses, and costs the picked keyframe one use.
// The mapper may narrow the cell to a window (restrict_to): the keyframes nearest the latest whose
// chunks fit the memory budget together, so that a small budget does not make every step load. A
// pick may still range over the whole cell (PickScope::cell): the mapper then trains a keyframe
// outside the window on the resident part of its view (view_coverage.hpp).
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <unordered_map>
#include <vector>

namespace chungs {

struct KeyframeSelectorConfig {
  // Metres. The paper's 200 m let views leave training while newer views still trained what they see:
  // on a 2 km street 300 steps per keyframe scored 0.9 dB under 30, and on a 1.5 km one 100 steps 2.5 dB
  // under 10. At 600 m, 300 steps score 0.4 dB above 30 and slower intakes score higher (bench/README.md,
  // issue 20).
  double cell_size = 600.0;
  // Under a training window (the budget cannot hold the cell's views) the cell is this size instead:
  // a keyframe beyond the window trains only the resident part of its view, and those of a wide cell
  // have little resident, so their picks fell back to the window (2 km at 100 k: -1.2 dB at 600 m).
  double budget_cell_size = 200.0;
  // Candidates are the keyframes within cell_size / 2 of the latest one rather than those of its grid
  // cell. A grid cell starts empty when the car crosses into it, so its first keyframes share all the
  // steps between a few views, and the keyframes just behind the border get none: on a 1 km street
  // the grid scored 1.0-1.2 dB below this at 30 and 100 steps per keyframe (bench/README.md).
  bool around_latest = true;
  // At most this many candidates, the nearest (0: no limit): the keyframes the paper keeps in VRAM, and
  // what the CUDA backend's image cache holds by default. A 600 m cell of keyframes a metre apart held
  // 523, and a step at 1241x376 then spent 1.4 ms fetching and uploading images (bench_step_loop).
  size_t max_candidates = 400;
  // A new keyframe's uses are spent at once, in a burst on its view alone; the rest of its steps come
  // from the refills, spread over its time in the cell. 4 instead of CaRtGS's 8 (2 km street, 30 steps
  // per keyframe, GPU): +0.35 dB held-out at the default budget, +0.25 dB at 300 k, the gain spread along
  // the whole drive; at 300 m and 310x94 on the CPU: +0.44 dB at 10 steps, +0.15 at 30, level at 5
  // (bench/README.md, issue 19).
  int new_uses = 4;
  double top_loss_fraction = 0.25;
  // The keyframes trained on together may need at most this share of the budget (their chunks'
  // Gaussians): the rest leaves room for new Gaussians and eviction's hysteresis.
  double budget_share = 0.85;
  // Under a window, steps still pick from the whole cell; a keyframe outside the window is trained on
  // the resident part of its view (pixels whose surface lies in a resident chunk) when that part
  // covers at least min_partial_coverage of the image, else a window keyframe is trained instead.
  // Loading such a keyframe's whole core instead was tried (a share of these picks, 2026-12-02): on the
  // CPU it gained 0.4 dB at the demo's budget, but on the GPU, whose steps are far shorter than a core's
  // loads, chunk loads rose 8-11x, the 72 km/h intake dropped 2-3x the keyframes and scored 0.4-0.5 dB
  // lower, and fixed pacing ran 7x slower (bench/README.md).
  bool partial_views = true;
  double min_partial_coverage = 0.2;
  // Under a window, a step leaves out the pixels of a chunk its view shows on fewer than this share of
  // the blocks its best view (the keyframe that showed it largest) did, once that view has left the
  // window: later views that glimpse it from afar or at a grazing angle would otherwise reshape what
  // nothing holds in place any more (2 km street at a 100 k budget: +1.1 dB held-out). With or without a
  // window, a keyframe samples nothing into such chunks (without a budget, glimpses had hazed a stretch of
  // a 2 km street; +0.5-0.7 dB held-out on it at 310x94, bench/README.md). 0: off.
  double best_view_share = 0.5;
  // When the map exceeds the budget, a view needs only its core chunks: the fewest, largest first, that
  // show this share of its 4x4 blocks (ViewCoverage::core); its other chunks are drawn when resident and
  // their pixels left out when not, and the training window is fitted to the cores. Far chunks hold many Gaussians for the few pixels they fill, and they set how many views fit
  // the budget together (2 km street at a 100 k budget: a window of 43 keyframes instead of 26, +0.4 dB
  // over best_view_share alone, and a quarter of the chunk loads). 1: every visible chunk.
  double core_share = 0.9;
  // Revisits: this share of the steps trains keyframes between revisit_min_distance and cell_size / 2
  // behind the latest one, whole (their cores loaded, as a window keyframe's), in bursts of revisit_burst
  // steps on the keyframes within revisit_group_m of one drawn at random, so that one load serves a burst.
  // A wide cell keeps places trained from the views that saw them long after the car passed: on a 600 m
  // street at 620x188 (CPU, 10 steps per keyframe, no budget) a 200 m cell scored 23.80 dB held-out
  // against 24.53 at 600 m, and with 20 % / 50 % of its picks on keyframes 100-300 m back 24.53 / 25.03;
  // an 80 k budget (a window of ~100 m) scored 23.82, as the 200 m cell. Off by default: in bursts of 32
  // on 10 m it gained 0.13 dB without a budget and nothing at 80 k; scattered (bursts of 1) at 0.3, +0.41 dB
  // without a budget but -0.1 dB under 80 k (77x the chunk loads). On the GPU (2 km street, 30 steps per
  // keyframe) revisits lower the map with or without a budget: 0.2 of the steps cost the default budget
  // 0.29 dB and a 300 k budget 0.28-0.66 dB, whether bursts walk back along the drive loading whole views
  // or land at random on cores; the CPU's 10 steps per keyframe had left far places undertrained, the
  // GPU's 600 m cell does not (bench/README.md, issue 19). 0: off.
  double revisit_share = 0.0;
  int revisit_burst = 32;
  double revisit_min_distance = 100.0;
  double revisit_group_m = 10.0;
  void validate() const;
};

struct KeyframeUsage {
  uint32_t id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  int uses = 0;
  double last_loss = 0;  // loss of its last step (0 before the first)
};

enum class PickScope { window, cell };

class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeSelectorConfig& config = {});
  // Registers a keyframe (the latest one defines the candidate cell). `uses` < 0 means new_uses.
  void add(uint32_t id, const Eigen::Vector3d& position, int uses = -1, double last_loss = 0);
  // Among the candidates (scope window) or the whole cell. Throws Error when no keyframe was added.
  uint32_t pick(std::mt19937_64& rng, PickScope scope = PickScope::window);
  void report_loss(uint32_t id, double loss);
  // Returns the use that pick() took from `id` (a pick made ahead of time and then not trained on).
  void give_back(uint32_t id);
  // Keyframes in the latest keyframe's cell (within the window, if one is set), ascending. While a
  // window is set the cell is budget_cell_size, and the window's keyframes are in it whatever their
  // distance.
  const std::vector<uint32_t>& candidates() const { return in_cell(PickScope::window); }
  // Whether the keyframe is a candidate of the window (true when there is none).
  bool in_window(uint32_t id) const;
  // Narrows the candidates to these keyframes until the next add(); empty: the whole cell. The
  // latest keyframe is always a candidate.
  void restrict_to(std::vector<uint32_t> ids);
  bool restricted() const { return !window_.empty(); }
  const KeyframeUsage& usage(uint32_t id) const;
  size_t size() const { return keyframes_.size(); }
  const KeyframeSelectorConfig& config() const { return config_; }
  std::vector<KeyframeUsage> all() const;  // ascending id (for saving)

 private:
  struct Cell {
    int64_t x, y, z;
    bool operator==(const Cell&) const = default;
  };
  Cell cell_of(const Eigen::Vector3d& p, double size) const;
  double current_cell_size() const { return window_.empty() ? config_.cell_size : config_.budget_cell_size; }
  const std::vector<uint32_t>& in_cell(PickScope scope) const;
  std::vector<uint32_t> find_in_cell(PickScope scope) const;
  KeyframeSelectorConfig config_;
  std::unordered_map<uint32_t, KeyframeUsage> keyframes_;
  std::vector<uint32_t> order_;  // insertion order
  uint32_t latest_ = 0;
  std::vector<uint32_t> window_;  // sorted; empty: no window
  // in_cell's answer per scope, until the next add() or restrict_to(): a step picks every few
  // milliseconds, and the scan over every keyframe of the run grows with the drive.
  mutable std::vector<uint32_t> cached_[2];
  mutable bool cache_valid_[2] = {false, false};
};

}  // namespace chungs
