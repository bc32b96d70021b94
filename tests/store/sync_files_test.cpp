// Flushing a checkpoint's files: thousands of chunks at once must not need a descriptor each (a
// checkpoint of 1 cm chunks failed with "Too many open files"; 1024 is a common limit).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

TEST(SyncFiles, FlushesMoreFilesThanTheProcessMayHaveOpen) {
  test::TempDir dir;
  std::vector<std::filesystem::path> files;
  for (int i = 0; i < 600; ++i) {
    files.push_back(dir / ("f" + std::to_string(i)));
    std::ofstream(files.back()) << i;
  }
  // In a child, so the lowered limit ends with it.
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const rlimit low{64, 64};
    if (setrlimit(RLIMIT_NOFILE, &low) != 0) _exit(3);
    try {
      sync_files(files);
    } catch (...) {
      _exit(1);
    }
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "sync_files of 600 files under a limit of 64 descriptors failed";
  // A file missing in a later batch is still named.
  std::filesystem::remove(files[400]);
  try {
    sync_files(files);
    ADD_FAILURE() << "a missing file was flushed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("f400: cannot open to flush it"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace chungs
