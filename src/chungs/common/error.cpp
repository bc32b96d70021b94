#include "chungs/common/error.hpp"

namespace chungs {

void require_file(const std::filesystem::path& p, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::exists(p, ec)) fail(p.string(), ": ", what, " does not exist");
  if (std::filesystem::is_directory(p, ec)) fail(p.string(), ": expected a ", what, ", found a folder");
}

void require_dir(const std::filesystem::path& p, const std::string& what) {
  std::error_code ec;
  if (!std::filesystem::exists(p, ec)) fail(p.string(), ": ", what, " does not exist");
  if (!std::filesystem::is_directory(p, ec)) fail(p.string(), ": expected a ", what, ", found a file");
}

}  // namespace chungs
