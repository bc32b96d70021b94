// Indoor RGB-D scene: a furnished room (walls of brick, wallpaper and plaster, plank floor, tiled
// ceiling, shelves of books, sofa, cabinet, paintings, a rug and a table) and a smooth periodic
// trajectory that circles the room looking at the walls and, half a loop later, across the centre.
#pragma once
#include <cstdint>
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/trajectory.hpp"
#include "chungs/synth/mesh.hpp"

namespace chungs::synth {

struct RoomOptions {
  uint64_t seed = 1;
  double size_x = 6.0, size_y = 5.0, height = 3.0;  // metres; z is up, the room spans [0, size]
  double loop_seconds = 20.0;                       // one trip around the room
  double rate_hz = 30.0;
  double start_time = 0.0;
};

// One mesh per object so that the per-mesh culling has something to cull.
std::vector<Mesh> build_room(const RoomOptions& opt);

// `frames` poses at rate_hz; the path repeats exactly every loop_seconds (loop closures).
Trajectory room_trajectory(const RoomOptions& opt, size_t frames);

// The TUM RGB-D default camera (525, 525, 319.5, 239.5) for 640x480, scaled for other sizes.
Camera tum_camera(int width = 640, int height = 480);

// Camera-to-world pose at `position` looking along `forward` (world z up), rolled by `roll`
// radians about the optical axis. OpenCV axes: x right, y down, z forward.
SE3 look_pose(const Eigen::Vector3d& position, const Eigen::Vector3d& forward, double roll = 0);

}  // namespace chungs::synth
