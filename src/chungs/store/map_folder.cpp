#include "chungs/store/map_folder.hpp"

#include "chungs/common/error.hpp"

namespace chungs {

namespace fs = std::filesystem;

void require_map_manifest(const fs::path& folder) {
  std::error_code ec;
  if (fs::is_regular_file(folder / "manifest.txt", ec)) return;
  if (fs::is_regular_file(folder / "keyframes.txt", ec))
    fail(folder.string(), ": manifest.txt is missing, though the map's keyframes.txt is there; `run --resume` with "
         "the map's dataset rebuilds it from the chunk files");
  fail(folder.string(), ": not a map folder (no manifest.txt)");
}

}  // namespace chungs
