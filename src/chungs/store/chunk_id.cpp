#include "chungs/store/chunk_id.hpp"

#include <cmath>
#include <cstdio>

#include "chungs/common/error.hpp"

namespace chungs {

namespace {
constexpr uint64_t kAxisMask = (uint64_t(1) << kChunkAxisBits) - 1;

bool axis_ok(int32_t v) { return v >= kChunkCoordMin && v <= kChunkCoordMax; }
}  // namespace

bool ChunkCoord::in_range() const { return axis_ok(x) && axis_ok(y) && axis_ok(z); }

std::string ChunkCoord::str() const { return cat("(", x, ", ", y, ", ", z, ")"); }

ChunkId chunk_id(const ChunkCoord& c) {
  if (!c.in_range())
    fail("chunk coordinate ", c.str(), " is outside the id range [", kChunkCoordMin, ", ",
         kChunkCoordMax, "] per axis");
  auto field = [](int32_t v) { return uint64_t(int64_t(v) + kChunkCoordOffset) & kAxisMask; };
  return (field(c.x) << (2 * kChunkAxisBits)) | (field(c.y) << kChunkAxisBits) | field(c.z);
}

ChunkCoord chunk_coord(ChunkId id) {
  id = near_level_of(id);
  auto axis = [&](int shift) { return int32_t(int64_t((id >> shift) & kAxisMask) - kChunkCoordOffset); };
  return {axis(2 * kChunkAxisBits), axis(kChunkAxisBits), axis(0)};
}

ChunkCoord chunk_coord_of(const Eigen::Vector3d& p, double s) {
  if (!(s > 0) || !std::isfinite(s)) fail("chunk size must be positive and finite, got ", s);
  int32_t out[3];
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(p[a]))
      fail("point (", p.x(), ", ", p.y(), ", ", p.z(), ") is not finite: it has no chunk");
    // Compare in double before converting: a huge value must fail, not overflow the int cast.
    const double c = std::floor((p[a] + 0.5 * s) / s);
    if (c < kChunkCoordMin || c > kChunkCoordMax)
      fail("point (", p.x(), ", ", p.y(), ", ", p.z(), ") lies in chunk ", c, " on axis ", a,
           ", outside the id range [", kChunkCoordMin, ", ", kChunkCoordMax, "] for chunk size ", s);
    out[a] = int32_t(c);
  }
  return {out[0], out[1], out[2]};
}

void chunk_box(const ChunkCoord& first, const ChunkCoord& last, double s, Eigen::Vector3d& lo,
               Eigen::Vector3d& hi) {
  lo = {chunk_lower_edge(first.x, s), chunk_lower_edge(first.y, s), chunk_lower_edge(first.z, s)};
  hi = {chunk_upper_edge(last.x, s), chunk_upper_edge(last.y, s), chunk_upper_edge(last.z, s)};
}

Eigen::Vector3d chunk_centre(const ChunkCoord& c, double s) {
  return {double(c.x) * s, double(c.y) * s, double(c.z) * s};
}

std::string chunk_name(ChunkId id) {
  char hex[24];
  std::snprintf(hex, sizeof hex, "0x%016llx", static_cast<unsigned long long>(id));
  return cat("chunk ", chunk_coord(id).str(), is_far_level(id) ? " far/" : "/", hex);
}

ChunkId level_for_view(ChunkId id, const Eigen::Vector3d& eye, double s, double far_distance) {
  const ChunkId near = near_level_of(id);
  if (!(far_distance > 0)) return near;
  const double d2 = (chunk_centre(chunk_coord(near), s) - eye).squaredNorm();
  return d2 > far_distance * far_distance ? far_level_of(near) : near;
}

}  // namespace chungs
