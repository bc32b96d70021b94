// The far-level distance a map was made with (chunk_id.hpp's two levels), kept in its manifest: the
// levels of its chunks were chosen by it, so everything that draws or trains the map uses it
// whatever the settings of the moment say.
#pragma once
#include <optional>

#include "chungs/store/chunk_store.hpp"

namespace chungs {

inline constexpr const char* kFarLevelKey = "far_level_distance";

// The map's distance in metres; 0 for a map made before chunks had levels (all of them near).
// Throws Error naming the manifest when the entry is not 0 or a positive number of metres.
double map_far_level_distance(const ChunkStore& store);
// Records `metres` in a map that has no chunks yet (committed with the next commit); for a map that
// has, leaves its own: 0 for one made before levels. A map with far-level chunks but no entry (its
// manifest rebuilt from the chunk files) gets `metres`, with a warning. Returns the distance the map keeps.
double settle_far_level_distance(ChunkStore& store, double metres);
// Writes the map's distance into its manifest's settings (committed with the next commit): for a
// manifest rebuilt from the chunk files, the distance the map's run state kept.
void record_far_level_distance(ChunkStore& store, double metres);

// For a reader that draws the map one way from everywhere (a PLY file, a point cloud): a far level
// whose cube has a near level too, left out so that no place is drawn twice; a place seen only from
// afar keeps its far level.
inline bool far_level_with_near_twin(const ChunkStore& store, ChunkId id) {
  return is_far_level(id) && store.contains(near_level_of(id));
}

}  // namespace chungs
