// Rendering a scanned mesh (PLY) along a recorded trajectory, and the office0 convention check:
// our render of the Replica office0 mesh at the first pose against the real depth image.
#pragma once
#include <filesystem>
#include <string>

#include "chungs/geometry/camera.hpp"
#include "chungs/synth/sequence.hpp"

namespace chungs::synth {

// NICE-SLAM style cam_params.json: {"camera": {"w", "h", "fx", "fy", "cx", "cy", "scale"}}.
Camera read_cam_params_json(const std::filesystem::path& file, double* depth_scale = nullptr);
// "fx,fy,cx,cy,width,height" or the path of a cam_params.json.
Camera parse_intrinsics(const std::string& spec);

struct MeshSequenceSpec {
  std::filesystem::path mesh, traj, out;
  Camera camera;
  SequenceOptions seq;
  size_t every = 1;       // use every N-th pose
  size_t max_frames = 0;  // 0: all
  double rate_hz = 30.0;  // stamps for trajectories without them (Replica traj.txt)
};
SequenceReport render_mesh_sequence(const MeshSequenceSpec& spec);

struct Office0Check {
  double median_abs_diff = 0;  // metres, over pixels valid in both depth images
  double mean_abs_diff = 0;
  size_t valid_pixels = 0, pixels = 0;
  double render_seconds = 0;
  size_t triangles = 0;
};
// `data` is the replica_office0 folder: office0_mesh.ply, cam_params.json, office0/traj.txt and
// office0/results/depth000000.png. Throws Error naming a missing file.
Office0Check check_office0(const std::filesystem::path& data);

}  // namespace chungs::synth
