// Settings of the mapping pipeline (pacing, keyframes, evaluation), with every default here.
#pragma once
#include <cstdint>
#include <string>

namespace chungs {

struct MapperConfig {
  std::string pacing = "fixed";     // fixed: iterations_per_keyframe steps per keyframe (deterministic);
                                    // anytime: frames arrive in real time, the mapper trains in between
  int iterations_per_keyframe = 30;
  int final_iterations = 0;         // refinement steps after the last frame
  double speed = 1.0;               // anytime: frames arrive at the dataset rate times this
  int keyframe_every = 1;           // every k-th training frame is a keyframe ...
  double keyframe_translation = 0;  // ... or (when > 0) once the camera moved this far (m) ...
  double keyframe_rotation_deg = 0; // ... or turned this much since the last keyframe
  int holdout_every = 8;            // frame i is never trained on when i % n == n - 1 (0: none)
  int frame_lookahead = 4;          // frames read ahead, each keyframe loaded (and its depth computed) on
                                    // its own thread while the map trains (0: only the current frame)
  double resolution = 1.0;          // images (and intrinsics) scaled by this before mapping
  std::string depth = "auto";       // auto | sensor | stereo | none
  int checkpoint_every = 5;         // keyframes between checkpoints (flush chunks, save state) ...
  double checkpoint_seconds = 0;    // ... or, when > 0, seconds between them: every checkpoint rewrites
                                    // each modified chunk, so long runs checkpoint by time
  uint64_t seed = 1;
  int eval_keyframe_stride = 1;     // paper protocol: score every n-th keyframe at the end (0: off)
  int max_saved_renders = 64;       // held-out renders written as PNG at most
  int loop_refine_iterations = 1000;         // steps on the junction after a loop closure (the paper's 1 k)
  double pose_update_min_translation = 0.01; // m: smaller keyframe moves from the tracker are not applied ...
  double pose_update_min_rotation_deg = 0.1; // ... unless it also turned this much
  bool in_core_only = false;        // comparison without out-of-core management: the run stops (with a
                                    // checkpoint and a report) once the map outgrows the budget
  std::string device = "auto";      // optimisation on auto | cuda | cpu (auto: cuda when a GPU is usable)
  void validate() const;
};

}  // namespace chungs
