#include "chungs/store/map_folder.hpp"

#include "chungs/common/error.hpp"

namespace chungs {

namespace fs = std::filesystem;

void require_map_manifest(const fs::path& folder) {
  std::error_code ec;
  if (fs::is_regular_file(folder / "manifest.txt", ec)) return;
  // Something else by that name (a folder, a FIFO, a link that leads nowhere or in a loop) is no lost
  // manifest: --resume would write a new one over it.
  if (fs::is_symlink(folder / "manifest.txt", ec) || fs::exists(fs::symlink_status(folder / "manifest.txt", ec)))
    fail((folder / "manifest.txt").string(), ": is not a regular file (a folder, FIFO, device or a link that leads to "
         "none); the map is left as it is");
  if (fs::is_regular_file(folder / "keyframes.txt", ec))
    fail(folder.string(), ": manifest.txt is missing, though the map's keyframes.txt is there; `run --resume` with "
         "the map's dataset rebuilds it from the chunk files");
  fail(folder.string(), ": not a map folder (no manifest.txt)");
}

}  // namespace chungs
