#include "chungs/store/disk_usage.hpp"

#include <sys/stat.h>

#include "chungs/common/error.hpp"

namespace chungs {

namespace fs = std::filesystem;

DiskUsage disk_usage(const fs::path& folder) {
  DiskUsage u;
  std::error_code ec;
  fs::recursive_directory_iterator it(folder, fs::directory_options::skip_permission_denied, ec), end;
  if (ec) fail(folder.string(), ": cannot list folder for its disk usage: ", ec.message());
  for (; it != end; it.increment(ec)) {
    if (ec) fail(folder.string(), ": cannot list folder for its disk usage: ", ec.message());
    struct stat st;
    if (::lstat(it->path().c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    ++u.files;
    u.bytes += uint64_t(st.st_size);
    u.allocated_bytes += uint64_t(st.st_blocks) * 512;
  }
  return u;
}

}  // namespace chungs
