// FrustumCuller: which chunks of the map a camera sees.
//
// Definition (the brute-force reference and the hierarchical culler implement exactly this):
// chunk c with cube B = [c*s - s/2, c*s + s/2]^3 is visible from camera-to-world pose T iff
//   (1) Frustum::intersects_box(B) holds for the frustum of view_projection_matrix(camera, T,
//       near, far) -- the conservative plane test: B is not entirely outside any of the 6 planes;
//   (2) the Euclidean distance from the camera centre T.t to the nearest point of B is at most
//       max_distance (the distance filter).
// The hierarchical culler tests octree nodes (tight boxes of groups of chunks): a node outside a
// plane or beyond the distance is rejected whole, a node inside all planes and entirely within
// the distance is accepted whole, otherwise its children are tested. Both shortcuts are exact
// (the tests are monotone in the box), so the result equals the brute-force loop's.
// Of each visible cube the result names the level a view from the camera centre draws
// (level_for_view, chunk_id.hpp), and only when the map holds that level: a far level not yet made
// leaves its cube's pixels to the sampler, and the near level of a cube the camera has reached
// likewise, instead of drawing what the other level holds for views it was not trained for.
// Results are cached per keyframe while its pose moves less than cache_translation * s and
// cache_rotation_rad, and the map's chunk set is unchanged.
#pragma once
#include <cstdint>
#include <span>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/frustum.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/residency/chunk_octree.hpp"

namespace chungs {

struct CullerConfig {
  double near = 0.05;                 // metres
  double far = 100.0;                 // far plane, metres (the paper's 100 m)
  double max_distance = 100.0;        // distance filter on the nearest point of a chunk, metres
  double cache_translation = 0.05;    // reuse a keyframe's result while it moves < this * chunk size
  double cache_rotation_rad = 0.05;   // ... and turns less than this
  size_t cache_max_entries = 4096;    // keyframes remembered; the cache is cleared beyond
  size_t parallel_min_chunks = 20000; // use threads only when this many chunks remain to test
                                      // after the top of the tree (bench/README.md)
  // Beyond this distance from a view (metres, to a chunk's centre) the view draws and trains the
  // chunk's far level (chunk_id.hpp); 0: one level. A map keeps the distance it was made with (its
  // manifest's far_level_distance). On a 2 km street at 620x188 (GPU, 30 steps per keyframe):
  // 27.70 dB held-out with one level, 27.73 / 27.90 / 28.04 / 28.42 / 27.99 at 30 / 40 / 50 / 70 /
  // 85 m; under a 100 k budget, below one view's need, 25.35 dB against 26.68-27.14 at 30-70 m
  // (bench/README.md, issue 19).
  double far_level_distance = 70.0;
};

struct CullStats {
  uint64_t culls = 0, cache_hits = 0, node_tests = 0;
};

class FrustumCuller {
 public:
  FrustumCuller(double chunk_size, const CullerConfig& config = {});

  // Replaces the set of chunks (the map's catalogue); `version` lets repeated calls with an
  // unchanged set skip the rebuild (Residency::catalogue_version()).
  void set_chunks(std::span<const ChunkId> ids, uint64_t version);
  template <typename Map>
  void set_chunks_from(const Map& catalogue, uint64_t version) {
    if (version == version_ && built_) return;
    std::vector<ChunkId> ids;
    ids.reserve(catalogue.size());
    for (const auto& kv : catalogue) ids.push_back(kv.first);
    set_chunks(ids, version);
  }

  // Visible chunks, ascending ids. Hierarchical, in parallel for large maps.
  std::vector<ChunkId> cull(const Camera& camera, const SE3& cam_to_world) const;
  // The same through the per-keyframe cache.
  std::vector<ChunkId> cull_cached(uint64_t keyframe, const Camera& camera, const SE3& cam_to_world);
  // The reference: every chunk tested on its own.
  std::vector<ChunkId> cull_brute_force(const Camera& camera, const SE3& cam_to_world) const;

  Frustum frustum(const Camera& camera, const SE3& cam_to_world) const;
  const CullerConfig& config() const { return config_; }
  size_t chunk_count() const { return octree_.size(); }
  CullStats stats() const { return stats_; }
  void clear_cache() { cache_.clear(); }

 private:
  struct CacheEntry {
    SE3 pose;
    Camera camera;
    uint64_t version;
    std::vector<ChunkId> visible;
  };
  bool chunk_visible(const Frustum& f, const Eigen::Vector3d& eye, const ChunkCoord& c) const;
  // The visible cubes' chunks at the levels a view from `eye` draws, those the map holds.
  std::vector<ChunkId> at_levels(std::vector<ChunkId> cubes, const Eigen::Vector3d& eye) const;
  std::unordered_set<ChunkId> ids_;  // the map's chunks, either level

  double chunk_size_;
  CullerConfig config_;
  ChunkOctree octree_;
  uint64_t version_ = 0;
  bool built_ = false;
  std::unordered_map<uint64_t, CacheEntry> cache_;
  mutable CullStats stats_;
};

// Squared distance from p to the nearest / farthest point of the box [lo, hi].
double box_near_distance_sq(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
double box_far_distance_sq(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);

}  // namespace chungs
