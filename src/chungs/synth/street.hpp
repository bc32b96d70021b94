// Outdoor street world: an endless city grid (roads on the lines x = i * pitch and y = j * pitch,
// blocks of buildings, sidewalks, trees, lamps, parked cars, parks), generated block by block from
// (seed, block index) when a camera first needs it, and dropped again (least recently used) when the
// cache is full (street_blocks.hpp): a 10 km drive holds a few hundred blocks, not the whole city. The route drives on
// the right lane, turns at intersections with rounded corners and comes back to streets it drove
// before (loops), so a chunked map must evict regions and reload them later.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "chungs/geometry/trajectory.hpp"
#include "chungs/synth/scene.hpp"
#include "chungs/synth/street_blocks.hpp"

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
  size_t max_blocks = 128;  // blocks kept in memory per cache (about 3 MB each at most; a dataset's renderers share one)
  // Moving vehicles (issue 23), all off by default: the world and the drive are then exactly as before.
  // The camera's poses never depend on them; only start_turn moves where the drive begins.
  double traffic = 0;         // moving vehicles per 100 m of route: ahead, oncoming and crossing
  bool startup_cross = false; // a lorry crosses close ahead in the first frames, filling much of the view
  bool start_turn = false;    // the drive begins a few metres before the route's first corner
};

// The KITTI odometry camera (fx = fy = 718.856 at 1241x376) scaled to another width, principal
// point at the image centre. Stereo baseline 0.54 m.
Camera kitti_camera(int width = 1241, int height = 376);
constexpr double kKittiBaseline = 0.54;
// Longest route a street may have (1000 km): beyond any drive we map, and a typo's 1e308 or inf
// is refused instead of building route nodes without end.
constexpr double kMaxStreetLengthM = 1e6;

struct StreetTraffic;  // street_traffic.cpp

class StreetWorld : public Scene {
 public:
  // `blocks`: a cache shared with other worlds of the same options (null: one of its own).
  explicit StreetWorld(const StreetOptions& opt, std::shared_ptr<StreetBlocks> blocks = nullptr);
  std::vector<const Mesh*> gather(const Camera& cam, const SE3& T_wc, double far) override;
  const Environment& environment() const override { return env_; }
  size_t triangles() const override;

  // Block (bx, by) spans [bx, bx + 1] * pitch in x and y (plus the roads on its west and south
  // edges). Generated on demand; the result is the same whatever the order of requests. The
  // reference holds while the block is in the cache (max_blocks later blocks at least).
  const Mesh& block(int bx, int by);
  size_t blocks_in_memory() const { return blocks_->in_memory(); }
  size_t blocks_generated() const { return blocks_->generated(); }  // including regenerations
  size_t distinct_blocks() const { return blocks_->distinct(); }
  size_t distinct_triangles() const { return blocks_->distinct_triangles(); }  // over all blocks touched
  // Moving vehicles: gather() adds those of `traffic` where they are at time `t` (seconds, the
  // trajectory's stamps). Without traffic the world is static and the time is ignored.
  void set_traffic(std::shared_ptr<const StreetTraffic> traffic) { traffic_ = std::move(traffic); }
  void set_time(double t) { time_ = t; }

 private:
  StreetOptions opt_;
  Environment env_;
  std::shared_ptr<StreetBlocks> blocks_;
  std::vector<std::shared_ptr<const Mesh>> in_use_;  // keeps the last gather's meshes alive
  std::shared_ptr<const StreetTraffic> traffic_;
  double time_ = 0;
  std::vector<std::shared_ptr<Mesh>> vehicles_;  // the last gather's vehicle meshes
};

// Builds the mesh of one block (street_block.cpp).
Mesh build_street_block(const StreetOptions& opt, int bx, int by);

// The route: intersections visited in order (grid indices), starting at (0, 0) heading east,
// long enough for opt.length_m. Starts with a loop around the first block.
std::vector<Eigen::Vector2i> street_route_nodes(const StreetOptions& opt);
// Camera poses every step_m along the route (at most max_frames when non-zero), stamps i / rate.
Trajectory street_trajectory(const StreetOptions& opt, size_t max_frames = 0);

// The route as a smooth right-lane path (lines and quarter circles, no sway), by arc length.
struct PathPiece {
  bool arc = false;
  Eigen::Vector2d a, b;          // line: from a to b
  Eigen::Vector2d c, din, dout;  // arc: centre and the directions in and out (quarter circle of radius r)
  double r = 0, length = 0;
  void at(double s, Eigen::Vector2d& p, Eigen::Vector2d& tangent) const;
};
class StreetPath {
 public:
  explicit StreetPath(const StreetOptions& opt);
  // Position and unit tangent at arc length s (clamped to the path).
  void at(double s, Eigen::Vector2d& p, Eigen::Vector2d& tangent) const;
  double length() const { return total_; }
  // The arc length reached from s after `distance` metres (negative: backwards) driven along the path
  // shifted `lateral` metres to its left (longer on the outside of a corner, shorter inside).
  double advance(double s, double distance, double lateral) const;
  // Arc length where the drive's frame 0 is: 0, or a few metres before the first corner (start_turn).
  double start() const { return start_; }
  const std::vector<PathPiece>& pieces() const { return pieces_; }
  const std::vector<Eigen::Vector2i>& nodes() const { return nodes_; }

 private:
  std::vector<Eigen::Vector2i> nodes_;
  std::vector<PathPiece> pieces_;
  std::vector<double> starts_;
  double total_ = 0, start_ = 0;
};

// Moving vehicles along a drive (street_traffic.cpp). Each has a box-like body (car, van or lorry) with
// the street's paint, glass and poster materials carried with it, and moves at 10-60 km/h: ahead of the
// camera in its lane, oncoming in the other lane, across intersections before the camera reaches them,
// and (startup_cross) a lorry crossing close ahead in the first frames. None comes within a metre of the
// camera, whose poses it does not change.
struct Vehicle {
  enum class Kind { Car, Van, Lorry } kind = Kind::Car;
  enum class Motion { Route, Line } motion = Motion::Route;
  double length = 4.3, width = 1.8, height = 1.5;
  double t0 = 0, t1 = 0;   // seconds it exists
  double speed = 10;       // m/s
  // Route: arc length s0 at t0, moving `dir` (+1 with the route, -1 against), `lateral` metres left of the path.
  double s0 = 0, dir = 1, lateral = 0;
  // Line: position p0 at t0 moving along the unit vector d.
  Eigen::Vector2d p0{0, 0}, d{1, 0};
  uint64_t seed = 0;  // paint and poster
  std::string role;   // ahead, oncoming, crossing, startup
};
struct StreetTraffic {
  StreetTraffic(const StreetOptions& opt, const Trajectory& drive);
  std::vector<Vehicle> vehicles;
  // Where vehicle v is at time t: centre of its footprint and unit heading; false outside [t0, t1].
  bool place(const Vehicle& v, double t, Eigen::Vector2d& centre, Eigen::Vector2d& heading) const;
  std::shared_ptr<Mesh> mesh(const Vehicle& v, double t) const;  // null outside its time

 private:
  StreetOptions opt_;
  StreetPath path_;
};

}  // namespace chungs::synth
