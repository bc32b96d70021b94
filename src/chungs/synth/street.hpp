// Outdoor street world: an endless city grid (roads on the lines x = i * pitch and y = j * pitch,
// blocks of buildings, sidewalks, trees, lamps, parked cars, parks), generated block by block from
// (seed, block index) when a camera first needs it, and dropped again (least recently used) when the
// cache is full: a 10 km drive holds a few hundred blocks, not the whole city. The route drives on
// the right lane, turns at intersections with rounded corners and comes back to streets it drove
// before (loops), so a chunked map must evict regions and reload them later.
#pragma once
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "chungs/geometry/trajectory.hpp"
#include "chungs/synth/scene.hpp"

namespace chungs::synth {

struct StreetOptions {
  uint64_t seed = 1;
  double length_m = 1000;    // route length
  double pitch = 50;         // distance between parallel road centrelines
  double road_width = 10;    // kerb to kerb: two 3 m lanes and 2 m of parking each side
  double sidewalk = 3;
  double step_m = 1.0;       // distance driven per frame
  double rate_hz = 10;
  double camera_height = 1.65;
  double lane_offset = 1.6;  // camera path right of the centreline (middle of a 3 m lane)
  double turn_radius = 6.0;
  double far = 150;          // far plane the world is culled to
  size_t max_blocks = 128;  // blocks kept in memory per renderer (about 3 MB each at most)
};

// The KITTI odometry camera (fx = fy = 718.856 at 1241x376) scaled to another width, principal
// point at the image centre. Stereo baseline 0.54 m.
Camera kitti_camera(int width = 1241, int height = 376);
constexpr double kKittiBaseline = 0.54;
// Longest route a street may have (1000 km): beyond any drive we map, and a typo's 1e308 or inf
// is refused instead of building route nodes without end.
constexpr double kMaxStreetLengthM = 1e6;

class StreetWorld : public Scene {
 public:
  explicit StreetWorld(const StreetOptions& opt);
  std::vector<const Mesh*> gather(const Camera& cam, const SE3& T_wc, double far) override;
  const Environment& environment() const override { return env_; }
  size_t triangles() const override;

  // Block (bx, by) spans [bx, bx + 1] * pitch in x and y (plus the roads on its west and south
  // edges). Generated on demand; the result is the same whatever the order of requests.
  const Mesh& block(int bx, int by);
  size_t blocks_in_memory() const { return cache_.size(); }
  size_t blocks_generated() const { return generated_; }        // including regenerations
  size_t distinct_blocks() const { return distinct_.size(); }
  size_t distinct_triangles() const;                           // over all distinct blocks touched

 private:
  struct Entry {
    std::shared_ptr<Mesh> mesh;
    uint64_t last_used = 0;
  };
  static int64_t key(int bx, int by) { return (int64_t(bx) << 32) ^ int64_t(uint32_t(by)); }
  void evict();

  StreetOptions opt_;
  Environment env_;
  std::unordered_map<int64_t, Entry> cache_;
  std::unordered_map<int64_t, size_t> distinct_;  // block -> triangles
  std::vector<std::shared_ptr<Mesh>> in_use_;     // keeps the last gather's meshes alive
  uint64_t clock_ = 0;
  size_t generated_ = 0;
};

// Builds the mesh of one block (street_block.cpp).
Mesh build_street_block(const StreetOptions& opt, int bx, int by);

// The route: intersections visited in order (grid indices), starting at (0, 0) heading east,
// long enough for opt.length_m. Starts with a loop around the first block.
std::vector<Eigen::Vector2i> street_route_nodes(const StreetOptions& opt);
// Camera poses every step_m along the route (at most max_frames when non-zero), stamps i / rate.
Trajectory street_trajectory(const StreetOptions& opt, size_t max_frames = 0);

}  // namespace chungs::synth
