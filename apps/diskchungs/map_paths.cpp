#include "map_paths.hpp"

#include "chungs/common/error.hpp"

namespace chungs::app {

namespace fs = std::filesystem;

namespace {
// Absolute, with links, `.`, `..` and a trailing slash resolved.
fs::path resolved(const std::string& p) {
  fs::path r = fs::weakly_canonical(fs::absolute(p));
  if (r.filename().empty()) r = r.parent_path();
  return r;
}
}  // namespace

void refuse_inside_map(const std::string& out, const std::string& map, const std::string& flag) {
  const fs::path m = resolved(map);
  for (fs::path p = resolved(out); !p.empty(); p = p.parent_path()) {
    if (p == m) fail(flag, " ", out, " lies inside the map folder ", map, "; a reader never writes there");
    if (p == p.root_path()) break;
  }
}

fs::path beside_map(const std::string& map, const std::string& suffix) {
  const fs::path m = resolved(map);
  return m.parent_path() / (m.filename().string() + suffix);
}

}  // namespace chungs::app
