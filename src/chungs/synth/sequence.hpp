// Renders a scene along a trajectory and writes it in a dataset layout, with a progress bar.
#pragma once
#include <filesystem>

#include "chungs/geometry/trajectory.hpp"
#include "chungs/synth/rasterizer.hpp"
#include "chungs/synth/scene.hpp"
#include "chungs/synth/writers.hpp"

namespace chungs::synth {

// Largest synthetic image side: a 16384 x 16384 frame with depth already takes about 2 GB, so a
// typed 100000 is refused before buffers are sized for it.
constexpr int kMaxImageSide = 16384;
// Most frames a generated sequence may have: its trajectory is built whole before the first frame
// (~120 bytes a pose), and a million frames (9 hours at 30 Hz) is beyond any test sequence.
constexpr size_t kMaxFrames = 1'000'000;

struct SequenceOptions {
  Layout layout = Layout::Tum;
  double baseline = 0.1;  // metres between the rectified stereo centres (KITTI layout)
  bool kitti_depth = true;  // also write depth/ in the KITTI layout
  RenderOptions render;
};

struct SequenceReport {
  size_t frames = 0;
  double seconds = 0;          // whole run: rendering and writing
  double render_seconds = 0;   // rendering only
  size_t max_triangles_drawn = 0;
  size_t max_scene_triangles = 0;  // most triangles the scene held in memory at once
};

// Renders every pose of `traj` (stamps are kept) with `cam` and writes the frames under `out`.
SequenceReport render_sequence(Scene& scene, const Trajectory& traj, const Camera& cam, const SequenceOptions& opt,
                               const std::filesystem::path& out);

// One stereo frame in memory (right is empty without a baseline).
struct RenderedFrame {
  Image8 left, right;
  ImageF depth;
};
void render_frame(Rasterizer& r, Scene& scene, const Camera& cam, const SE3& T_wc, double baseline,
                  const RenderOptions& opt, RenderedFrame& out, RenderStats* stats = nullptr);

}  // namespace chungs::synth
