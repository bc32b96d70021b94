// Settings of the mapping pipeline (pacing, keyframes, evaluation), with every default here.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

namespace chungs {

// The slowest intake anytime pacing takes: a hundredth of the recorded rate. Slower, a run of a few
// frames waited for ever (--speed 1e-320 put the second frame 1e319 s after the first).
inline constexpr double kMinSpeed = 0.01;
// The fastest: a thousand times the recorded rate (10 kHz for KITTI). Beyond, 1e308 gave an intake of inf
// km/h in reports, and every frame arrived at once.
inline constexpr double kMaxSpeed = 1000;
// The automatic refinement's steps a keyframe at most, however many groups a small budget makes, unless
// half the drive's own steps are more (a drive of many steps a keyframe: MapperConfig::refinement_steps).
inline constexpr uint64_t kMaxRefinementStepsPerKeyframe = 16;
// A group's steps in the automatic refinement at least, in keyframes of the drive's mean steps a keyframe.
inline constexpr uint64_t kRefinementGroupDriveKeyframes = 4;

struct MapperConfig {
  std::string pacing = "fixed";     // fixed: iterations_per_keyframe steps per keyframe (deterministic);
                                    // anytime: frames arrive in real time, the mapper trains in between
  int iterations_per_keyframe = 30;
  // Refinement steps after the last frame, spread over every keyframe (mapping/refinement_plan.hpp).
  // -1: one a keyframe in either pacing, and under fixed pacing at least 4 x iterations_per_keyframe (a
  // map of few keyframes: mapper_config.cpp) (2 km street, GPU: +0.5-0.7 dB at every budget under fixed pacing
  // for ~3-5 % of the run; under anytime pacing 300 k came from -0.93..-1.08 to -0.45..-0.49 dB of the
  // default budget for 1.8-15 s after a 100 s drive, bench/README.md). Under anytime pacing the steps come
  // after the intake has ended, so they never slow the rate that keeps up with it; they count in the run's time.
  int final_iterations = -1;
  // Rounds over the refinement's groups (refinement_visits): each visit a group's next share of its
  // steps, loading the group's chunks again. More rounds bring the order nearer to the whole map at
  // random, which scored as if the map were resident. GPU, 2 km street under 300 k: 1 / 4 / 16 / 1000
  // rounds 27.17 / 27.21 / 27.43 / 27.41 dB against 27.68 without a budget, I/O wait 1.27 / 1.29 / 1.65 /
  // 3.11 % side by side; 16 rounds alone 4.5 %, bound by the disk's write bandwidth (bench/README.md, issue 19). A group is visited at most once per refinement_min_visit_steps
  // of its steps, so that a visit's loads stay a share of a view per step, but at least once per step of
  // each of its keyframes, so that more steps never train one view several times in a row (refinement_plan.hpp).
  int refinement_rounds = 16;
  int refinement_min_visit_steps = 4;
  // With final_iterations -1, the refinement's steps a group gets at least when the map is refined in
  // several groups (a budget below the map), or the drive's steps of kRefinementGroupDriveKeyframes
  // keyframes where those are more; up to kMaxRefinementStepsPerKeyframe a keyframe or half the drive's
  // steps, whichever is more, and never more than the drive's steps. A map that fits is one group and
  // keeps one step a keyframe. 2 km street at 620x188 under 100 k (134-175 groups of ~6.5 views, GPU):
  // fixed pacing 27.13 dB held-out with 1,034 steps, 27.86 with 64 a group, 27.98 with 128 (16,544, the
  // cap), against 28.38 without a budget; 36 km/h (65 steps a keyframe in the drive) -0.67 dB with 16,544
  // steps, -0.47 with 33,088, -0.37 with 49,632 (bench/README.md, issue 19).
  int refinement_group_steps = 128;
  double speed = 1.0;               // anytime: frames arrive at the dataset rate times this (>= kMinSpeed)
  // A training frame becomes a keyframe when any rule that is on (> 0) fires; the first always does.
  // By default the view must have changed: moved by a share of the scene's depth (parallax) or
  // turned. Every frame a keyframe floods a real-time intake with ingestion work.
  int keyframe_every = 0;           // every k-th training frame (0: off)
  double keyframe_translation = 0;  // metres moved since the last keyframe (0: off)
  double keyframe_parallax = 0.1;   // metres moved / median depth of the last keyframe (0: off)
  double keyframe_rotation_deg = 5; // degrees turned since the last keyframe (0: off)
  int min_steps_per_keyframe = 10;  // anytime: steps each keyframe gets at least; when the intake runs
                                    // ahead, a keyframe that a later loaded one supersedes is dropped
  int holdout_every = 8;            // frame i is never trained on when i % n == n - 1 (0: none)
  int frame_lookahead = 4;          // frames read ahead, each keyframe loaded (and its depth computed) on
                                    // its own thread while the map trains (0: only the current frame)
  int read_ahead_steps = 4;         // steps whose keyframes are drawn ahead, their chunks and images read in
                                    // the background (a view's chunk loads outlast one step on the GPU)
  double resolution = 1.0;          // images (and intrinsics) scaled by this before mapping
  std::string depth = "auto";       // auto | sensor | stereo | multiview | none (run: as multiview)
  // A checkpoint (the resume point) is due every checkpoint_seconds, or every checkpoint_every
  // keyframes (0: off), but only while the optimiser time checkpoints have cost so far, plus the
  // expected cost of the final one (which the run waits for), is at most checkpoint_max_share of the
  // run (0: no such bound; pipeline/checkpoint_cadence.hpp): their cost grows with the chunks modified
  // meanwhile, so the cadence adapts to the map and the disk. Each writes only what changed since the last.
  int checkpoint_every = 0;
  double checkpoint_seconds = 30;
  double checkpoint_max_share = 0.01;
  uint64_t seed = 1;
  int eval_keyframe_stride = 1;     // paper protocol: score every n-th keyframe at the end (0: off)
  int max_saved_renders = 64;       // held-out renders written as PNG at most
  std::string lpips_weights;        // DCLPIPS1 file (scripts/lpips_convert.py); empty: no LPIPS
  // Monocular input: an ONNX depth model (depth/learned_depth.hpp has the contract) run through ONNX
  // Runtime, its relative inverse depth aligned to the tracker's points; empty: no learned depth.
  std::string mono_depth_model;
  int loop_refine_iterations = 1000;         // steps on the junction after a loop closure (the paper's 1 k)
  double pose_update_min_translation = 0.01; // m: smaller keyframe moves from the tracker are not applied ...
  double pose_update_min_rotation_deg = 0.1; // ... unless it also turned this much
  bool in_core_only = false;        // comparison without out-of-core management: the run stops (with a
                                    // checkpoint and a report) once the map outgrows the budget
  std::string device = "auto";      // optimisation on auto | cuda | cpu (auto: cuda when a GPU is usable)
  // On the GPU: VRAM that keeps keyframe images for the steps (least recently used go first), so a
  // step uploads nothing; never more keyframes than selector.max_candidates (400, as the paper keeps).
  // 2 GB holds ~620 KITTI keyframes at full resolution, so the 400 fit (1.3 GB).
  int gpu_keyframe_cache_mb = 2048;
  // final_iterations resolved for a map of this many keyframes, refined in this many groups, after a
  // drive of this many steps (Mapper::refinement_steps).
  uint64_t refinement_steps(size_t keyframes, size_t groups = 1, uint64_t drive_steps = UINT64_MAX) const;
  void validate() const;
};

}  // namespace chungs
