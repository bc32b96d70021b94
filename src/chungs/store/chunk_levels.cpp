#include "chungs/store/chunk_levels.hpp"

#include <cmath>
#include <charconv>
#include <string>

#include "chungs/common/error.hpp"
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
  if (store.size() > 0 || store.config_value(kFarLevelKey)) return map_far_level_distance(store);
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, metres).ptr;  // shortest that reads back
  store.set_config(kFarLevelKey, std::string(text, end));
  return metres;
}

}  // namespace chungs
