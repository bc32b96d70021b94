// Helpers shared by the unit tests: where the real data excerpts are, and scratch folders.
#pragma once
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#ifdef CHUNGS_WITH_CUDA
#include "chungs/cuda/devices.hpp"
#endif

namespace chungs::test {

// ../shared/data beside the checkout; tests that need it skip with a message when it is absent.
inline std::filesystem::path shared_data(const std::string& sub = "") {
  std::filesystem::path p = CHUNGS_SHARED_DATA;
  return sub.empty() ? p : p / sub;
}

#define CHUNGS_REQUIRE_DATA(sub)                                                              \
  do {                                                                                        \
    if (!std::filesystem::exists(::chungs::test::shared_data(sub)))                           \
      GTEST_SKIP() << "real data not found at " << ::chungs::test::shared_data(sub)           \
                   << " (../shared/data is absent in a plain clone)";                         \
  } while (0)

#ifdef CHUNGS_WITH_CUDA
// GPU tests skip (with the driver's reason) where no CUDA device is present, as in CI.
#define CHUNGS_REQUIRE_GPU()                                                                   \
  do {                                                                                         \
    std::string why_;                                                                          \
    if (::chungs::cuda::list_devices(&why_).empty()) GTEST_SKIP() << "no CUDA device: " << why_; \
  } while (0)
#endif

// A fresh empty folder under the system temp dir, removed when the object dies.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("chungs_test_" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& s) const { return path_ / s; }

 private:
  std::filesystem::path path_;
};

// A file's bytes ("" when it cannot be read).
inline std::string read_all(const std::filesystem::path& file) {
  std::ifstream f(file, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// The process's resident memory now (/proc/self/statm), for tests of what the heap keeps.
inline size_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  size_t pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * size_t(::sysconf(_SC_PAGESIZE));
}

}  // namespace chungs::test
