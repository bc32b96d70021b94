// Chunk coordinates and their 64-bit ids. The world is cut into cubes of side s centred on the
// integer multiples of s: coordinate floor((p + s/2) / s) per axis. An id packs three 21-bit
// fields, each the coordinate plus 2^20, so coordinates span [-2^20, 2^20 - 1]; outside that range
// packing fails instead of wrapping into another chunk.
//
// Each cube has two levels of detail, two chunks: the near level (the id as packed) holds what
// views from within far_distance of the cube's centre draw and train, the far level (the same id
// with its top bit set) what views from farther away draw and train. A distant place fills few
// pixels, so its far level holds few, large Gaussians, and a view that reaches 100 m needs far
// fewer Gaussians resident than when its distant chunks held what near views made there.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>

namespace chungs {

using ChunkId = uint64_t;

constexpr int kChunkAxisBits = 21;
constexpr int32_t kChunkCoordOffset = 1 << 20;
constexpr int32_t kChunkCoordMin = -kChunkCoordOffset;
constexpr int32_t kChunkCoordMax = kChunkCoordOffset - 1;
// The chunk edges a map may have, in metres. Ids reach 2^20 chunks from the origin per axis, so
// 1 cm chunks span +-10 km, more than one session maps; much smaller ones run out of ids within
// metres, with nothing gained (a Gaussian is rarely smaller than a millimetre).
constexpr double kMinChunkSize = 0.01;
constexpr double kMaxChunkSize = 10000;

struct ChunkCoord {
  int32_t x = 0, y = 0, z = 0;

  bool operator==(const ChunkCoord&) const = default;
  auto operator<=>(const ChunkCoord&) const = default;
  bool in_range() const;
  std::string str() const;  // "(x, y, z)"
};

// Throws Error naming the coordinate when an axis lies outside [kChunkCoordMin, kChunkCoordMax].
ChunkId chunk_id(const ChunkCoord& c);
ChunkCoord chunk_coord(ChunkId id);  // of either level
// The chunk of a world point; throws on non-finite points, s <= 0, or a coordinate out of range.
ChunkCoord chunk_coord_of(const Eigen::Vector3d& p, double chunk_size);
inline ChunkId chunk_id_of(const Eigen::Vector3d& p, double chunk_size) {
  return chunk_id(chunk_coord_of(p, chunk_size));
}

// Axis-aligned bounds of a run of chunks [first, last] (inclusive), in world metres. The culler and
// its brute-force check both derive boxes from here so that they see bit-identical corners.
inline double chunk_lower_edge(int32_t c, double s) { return double(c) * s - 0.5 * s; }
inline double chunk_upper_edge(int32_t c, double s) { return double(c) * s + 0.5 * s; }
void chunk_box(const ChunkCoord& first, const ChunkCoord& last, double s, Eigen::Vector3d& lo,
               Eigen::Vector3d& hi);
inline void chunk_box(const ChunkCoord& c, double s, Eigen::Vector3d& lo, Eigen::Vector3d& hi) {
  chunk_box(c, c, s, lo, hi);
}
Eigen::Vector3d chunk_centre(const ChunkCoord& c, double s);

std::string chunk_name(ChunkId id);  // "(x, y, z)/0x0123456789abcdef", "(x, y, z) far/0x..." for messages

constexpr ChunkId kFarLevelBit = ChunkId(1) << 63;
inline bool is_far_level(ChunkId id) { return (id & kFarLevelBit) != 0; }
inline ChunkId near_level_of(ChunkId id) { return id & ~kFarLevelBit; }
inline ChunkId far_level_of(ChunkId id) { return id | kFarLevelBit; }
// The level of chunk `id`'s cube (either level given) that a view from `eye` draws: the far one
// when the cube's centre lies more than far_distance away; with far_distance <= 0 (one level)
// always the near one.
ChunkId level_for_view(ChunkId id, const Eigen::Vector3d& eye, double chunk_size, double far_distance);

// Where a view's points go: the chunk of a point at the level a view from `eye` draws. From a bare
// chunk size (implicitly), a grid of one level.
struct ChunkGrid {
  double size = 10.0;
  double far_level_distance = 0;  // metres; 0: one level
  ChunkGrid(double size_m, double far_level_m = 0) : size(size_m), far_level_distance(far_level_m) {}
  ChunkId for_view(const Eigen::Vector3d& p, const Eigen::Vector3d& eye) const {
    return level_for_view(chunk_id_of(p, size), eye, size, far_level_distance);
  }
};

}  // namespace chungs

template <>
struct std::hash<chungs::ChunkCoord> {
  size_t operator()(const chungs::ChunkCoord& c) const noexcept {
    return std::hash<uint64_t>()((uint64_t(uint32_t(c.x)) * 0x9E3779B97F4A7C15ull) ^
                                 (uint64_t(uint32_t(c.y)) << 21) ^ uint64_t(uint32_t(c.z)));
  }
};
