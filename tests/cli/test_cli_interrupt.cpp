// Ctrl-C during `run`: the map is committed where the run stood, the exit status is 130 with a line
// saying how to go on, and `--resume` finishes the run. Before, SIGINT ended the process at once and
// the frames since the last checkpoint (up to a minute of mapping) were lost without a word.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

extern char** environ;

using chungs::test::read_all;
using chungs::test::run_cli;
namespace fs = std::filesystem;

namespace {


size_t files_in(const fs::path& dir) {
  std::error_code ec;
  size_t n = 0;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) ++n;
  return n;
}

// The CLI started with SIGINT and SIGTERM at their default actions (a test run from a background job
// inherits them ignored, which the CLI then keeps), its output in `log`.
pid_t spawn_cli(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all{CHUNGS_CLI};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_addopen(&files, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&files, 1, 2);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t defaults;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGINT);
  sigaddset(&defaults, SIGTERM);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGDEF);
  pid_t pid = -1;
  const int err = posix_spawn(&pid, all[0].c_str(), &files, &attr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  posix_spawnattr_destroy(&attr);
  return err == 0 ? pid : -1;
}

TEST(CliInterrupt, CtrlCCommitsTheMapWhereTheRunStoodAndResumeFinishesIt) {
  chungs::test::TempDir dir;
  const fs::path map = dir / "map", log = dir / "log.txt";
  // Long enough (300 frames at 100 steps a keyframe) to be stopped well before its end on any machine.
  const std::string dataset = "synth-street:length=300,width=64,height=48,seed=2";
  const pid_t pid = spawn_cli({"run", "--dataset", dataset, "--poses", "gt", "--device", "cpu", "--iterations", "100",
                               "--final-iterations", "0", "--no-eval", "--out", map.string()},
                              log);
  ASSERT_GT(pid, 0);
  // A few keyframes in, whatever the machine's speed.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (files_in(map / "keyframes") < 4 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_GE(files_in(map / "keyframes"), 4u) << read_all(log);
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const std::string said = read_all(log);
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status) << "\n" << said;
  EXPECT_EQ(WEXITSTATUS(status), 130) << said;
  EXPECT_NE(said.find("stopping after the step under way"), std::string::npos) << said;
  EXPECT_NE(said.find("interrupted at frame "), std::string::npos) << said;
  EXPECT_NE(said.find("with --resume maps the rest"), std::string::npos) << said;
  EXPECT_FALSE(fs::exists(map / "report.json")) << "an interrupted run is not reported as finished";
  const auto state = nlohmann::json::parse(read_all(map / "run_state.json"));
  const size_t next = state["next_frame"].get<size_t>();
  EXPECT_GT(next, 3u);
  EXPECT_LT(next, 301u);
  EXPECT_FALSE(state["finished"].get<bool>());
  EXPECT_NE(said.find(" of 301: "), std::string::npos) << said;

  auto r = run_cli("-q run --dataset " + dataset + " --poses gt --device cpu --iterations 1 --final-iterations 0 "
                   "--no-eval --out " + map.string() + " --resume");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto done = nlohmann::json::parse(read_all(map / "run_state.json"));
  EXPECT_EQ(done["next_frame"].get<size_t>(), 301u);
  EXPECT_TRUE(done["finished"].get<bool>());
  EXPECT_TRUE(fs::exists(map / "report.json"));
}

// A keyframe's steps are cut short by a stop: with 10^9 steps a keyframe (fixed pacing) or a floor of 10^9
// (anytime), Ctrl-C and SIGTERM used to wait for all of them, so the run could only be killed.
TEST(CliInterrupt, AStopCutsAKeyframesStepsShort) {
  chungs::test::TempDir dir;
  const fs::path cfg = dir / "floor.yaml";
  std::ofstream(cfg) << "mapper: {pacing: anytime, min_steps_per_keyframe: 1000000000}\n";
  const std::vector<std::vector<std::string>> kinds{{"--iterations", "1000000000"}, {"--config", cfg.string()}};
  for (size_t k = 0; k < kinds.size(); ++k) {
    const fs::path map = dir / ("map" + std::to_string(k)), log = dir / ("log" + std::to_string(k) + ".txt");
    std::vector<std::string> args{"run", "--dataset", "synth-street:length=40,width=64,height=48,seed=2", "--poses",
                                  "gt", "--device", "cpu", "--no-eval", "--out", map.string()};
    args.insert(args.end(), kinds[k].begin(), kinds[k].end());
    const pid_t pid = spawn_cli(args, log);
    ASSERT_GT(pid, 0);
    // In the first keyframe's steps once its image is stored.
    auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(5);
    while (files_in(map / "keyframes") < 1 && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_GE(files_in(map / "keyframes"), 1u) << read_all(log);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ASSERT_EQ(kill(pid, SIGTERM), 0);
    int status = 0;
    pid_t got = 0;
    give_up = std::chrono::steady_clock::now() + std::chrono::minutes(2);
    while ((got = waitpid(pid, &status, WNOHANG)) == 0 && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (got == 0) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      FAIL() << kinds[k][0] << ": still stepping 2 minutes after SIGTERM\n" << read_all(log);
    }
    const std::string said = read_all(log);
    ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status) << "\n" << said;
    EXPECT_EQ(WEXITSTATUS(status), 130) << said;
    EXPECT_NE(said.find("interrupted at frame "), std::string::npos) << said;
    const auto state = nlohmann::json::parse(read_all(map / "run_state.json"));
    EXPECT_FALSE(state["finished"].get<bool>());
    EXPECT_GE(state["next_frame"].get<size_t>(), 1u) << state.dump();  // the first keyframe is in the map
  }
}

// Ctrl-C while the finished map is scored: scoring a long drive takes minutes, and the first Ctrl-C
// used to be ignored there. It now stops scoring; the report is written without scores (a mean over
// the frames scored so far would read as the map's), and --resume scores the map.
TEST(CliInterrupt, CtrlCWhileScoringWritesTheReportWithoutScoresAndResumeScores) {
  chungs::test::TempDir dir;
  const fs::path map = dir / "map", log = dir / "log.txt", cfg = dir / "c.yaml";
  // Every other frame held out and every keyframe scored: seconds of scoring, caught by polling.
  std::ofstream(cfg) << "mapper: {holdout_every: 2, eval_keyframe_stride: 1}\n";
  const std::vector<std::string> common{"--dataset", "synth-street:length=200,width=96,height=48,seed=2", "--poses",
                                        "gt", "--device", "cpu", "--iterations", "1", "--final-iterations", "0",
                                        "--config", cfg.string(), "--out", map.string()};
  auto args = [&](std::vector<std::string> more) {
    std::vector<std::string> all = common;
    all.insert(all.end(), more.begin(), more.end());
    std::string line;
    for (const std::string& a : all) line += a + " ";
    return std::make_pair(all, line);
  };
  auto made = run_cli("-q run " + args({"--no-eval"}).second);
  ASSERT_EQ(made.code, 0) << made.out;
  const pid_t pid = spawn_cli([&] {
    auto a = args({"--resume"}).first;
    a.insert(a.begin(), "run");
    return a;
  }(), log);
  ASSERT_GT(pid, 0);
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (read_all(log).find("scoring heldout") == std::string::npos && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const std::string said = read_all(log);
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status) << "\n" << said;
  ASSERT_EQ(WEXITSTATUS(status), 130) << said;
  EXPECT_NE(said.find("interrupted while scoring: "), std::string::npos) << said;
  EXPECT_NE(said.find("with --resume scores it"), std::string::npos) << said;
  const auto stopped = nlohmann::json::parse(read_all(map / "report.json"));
  EXPECT_NE(stopped["held_out"].value("none", std::string()).find("scoring was stopped after "), std::string::npos)
      << stopped["held_out"].dump();
  EXPECT_FALSE(stopped["held_out"].contains("mean_psnr"));
  EXPECT_TRUE(stopped["interrupted"]["scoring"].get<bool>());
  EXPECT_TRUE(nlohmann::json::parse(read_all(map / "run_state.json"))["finished"].get<bool>());

  auto scored = run_cli("-q run " + args({"--resume"}).second);
  ASSERT_EQ(scored.code, 0) << scored.out;
  const auto report = nlohmann::json::parse(read_all(map / "report.json"));
  EXPECT_GT(report["held_out"]["mean_psnr"].get<double>(), 5.0) << report["held_out"].dump();
  EXPECT_FALSE(report.contains("interrupted"));
}

}  // namespace
