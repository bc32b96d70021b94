#include "chungs/store/chunk_levels.hpp"

#include <cmath>
#include <charconv>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/common/text_file.hpp"

namespace chungs {

double map_far_level_distance(const ChunkStore& store) {
  const std::optional<std::string> v = store.config_value(kFarLevelKey);
  if (!v) return 0;
  const double d = parse_double(*v, store.manifest_path().string() + ": " + kFarLevelKey);
  if (!(d >= 0)) fail(store.manifest_path().string(), ": ", kFarLevelKey, " must be 0 or a positive number of metres, got ", *v);
  return d;
}

double settle_far_level_distance(ChunkStore& store, double metres) {
  if (store.config_value(kFarLevelKey)) return map_far_level_distance(store);
  if (store.size() > 0) {
    // Ids ascend and the far level is the top bit: the last id says whether the map has levels.
    const std::vector<ChunkId> ids = store.ids();
    if (!is_far_level(ids.back())) return 0;  // made before chunks had levels: all near
    log::warn(store.manifest_path().string(), ": the map has far-level chunks but its manifest does not say beyond "
              "what distance (rebuilt from the chunk files?); taking culling.far_level_distance, ", metres, " m");
  }
  record_far_level_distance(store, metres);
  return metres;
}

void record_far_level_distance(ChunkStore& store, double metres) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, metres).ptr;  // shortest that reads back
  store.set_config(kFarLevelKey, std::string(text, end));
}

}  // namespace chungs
