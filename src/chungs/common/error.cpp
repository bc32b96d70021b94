#include "chungs/common/error.hpp"

namespace chungs {

void require_file(const std::filesystem::path& p, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::exists(p, ec)) fail(p.string(), ": ", what, " does not exist");
  if (std::filesystem::is_directory(p, ec)) fail(p.string(), ": expected a ", what, ", found a folder");
  // A FIFO, socket or device would block a read forever or never end: only regular files (or links
  // to them) are inputs.
  if (!std::filesystem::is_regular_file(p, ec))
    fail(p.string(), ": expected a ", what, ", found a FIFO, socket or device (not a regular file)");
}

void prepare_output_file(const std::filesystem::path& p, const std::string& what) {
  std::error_code ec;
  if (p.has_parent_path() && !std::filesystem::create_directories(p.parent_path(), ec) && ec)
    fail(p.string(), ": cannot make the folder ", p.parent_path().string(), " for the ", what, ": ", ec.message());
  if (std::filesystem::is_directory(p, ec)) fail(p.string(), ": is a folder, not a file for the ", what);
  // Writing a FIFO (or socket) waits for a reader that may never come; a device (/dev/null) is written in place.
  if (std::filesystem::is_fifo(p, ec) || std::filesystem::is_socket(p, ec))
    fail(p.string(), ": is a FIFO or socket, not a file for the ", what);
}

void require_dir(const std::filesystem::path& p, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::exists(p, ec)) fail(p.string(), ": ", what, " does not exist");
  if (!std::filesystem::is_directory(p, ec)) fail(p.string(), ": expected a ", what, ", found a file");
}

}  // namespace chungs
