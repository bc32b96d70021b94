// Memory in proportion to the map (issue 21): a tiny run and a render of its map at the default
// budget (1.5 M Gaussians) stay far below what the budget would take. Before, both allocated the
// whole Gaussian pool up front, and run the budget's heap reserve too: 1.35 GB and 1.06 GB peak RSS.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

struct Measured {
  int code = -1;
  double peak_mb = 0;
};

// Runs the CLI (no shell) with its output discarded and measures the child's own peak RSS.
Measured run_measured(const std::vector<std::string>& args) {
  std::vector<char*> argv{const_cast<char*>(CHUNGS_CLI)};
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) return {};
  if (pid == 0) {
    if (!freopen("/dev/null", "w", stdout) || !freopen("/dev/null", "w", stderr)) _exit(126);
    execv(CHUNGS_CLI, argv.data());
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid) return {};
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, double(usage.ru_maxrss) / 1024.0};  // kB on Linux
}

TEST(CliMemory, ATinyRunAndItsRenderTakeMemoryForTheMapNotTheBudget) {
  chungs::test::TempDir dir;
  const fs::path map = dir / "map";
  const Measured run =
      run_measured({"-q", "run", "--dataset", "synth-street:length=30,width=160,height=48,seed=2", "--device",
                    "cpu", "--max-frames", "12", "--no-eval", "--out", map.string()});
  ASSERT_EQ(run.code, 0);
  EXPECT_LT(run.peak_mb, 300) << "peak RSS of a 12-frame run at the default budget";
  const Measured render =
      run_measured({"-q", "render", "--map", map.string(), "--poses", (map / "trajectory.txt").string(),
                    "--stride", "6", "--budget", "1500000", "--out", (dir / "renders").string()});
  ASSERT_EQ(render.code, 0);
  EXPECT_LT(render.peak_mb, 300) << "peak RSS of its render at the default budget";
}

}  // namespace
