// End to end on a tiny synthetic RGB-D sequence: quality rises, the map folder reopens with the
// same Gaussians, a small budget is never exceeded, and a run killed with SIGKILL resumes.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <thread>

#include "chungs/common/log.hpp"
#include "chungs/common/text_file.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "mapping/synthetic_sequence.hpp"
#include "test_support.hpp"
#include "mapping/tiny_config.hpp"

extern char** environ;

namespace chungs {
namespace {

Config tiny_config() { return test::tiny_mapping_config(); }

RunOptions options(const std::filesystem::path& out, const Config& c) {
  RunOptions o;
  o.dataset = "synthetic:wall";
  o.out = out;
  o.config = c;
  return o;
}

TEST(MappingRun, HeldOutQualityRisesAndTheFolderReopens) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(16);
  Config c = tiny_config();
  // Baseline: the same run with almost no optimisation.
  Config c0 = c;
  c0.mapper.iterations_per_keyframe = 0;
  c0.mapper.final_iterations = 0;
  const auto r0 = run_mapping(options(dir / "untrained", c0), seq);
  const auto r = run_mapping(options(dir / "map", c), seq);
  const double p0 = r0["held_out"]["mean_psnr"], p = r["held_out"]["mean_psnr"];
  std::printf("held-out PSNR: %.2f dB untrained, %.2f dB trained (%zu Gaussians)\n", p0, p,
              r["gaussians"]["total"].get<size_t>());
  EXPECT_EQ(r["held_out"]["count"].get<size_t>(), 2u);  // frames 7 and 15
  EXPECT_GT(p, 20.0);
  EXPECT_GT(p, p0 + 5.0);
  EXPECT_TRUE(std::filesystem::exists(dir / "map" / "report.json"));
  EXPECT_TRUE(std::filesystem::exists(dir / "map" / "timeline.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir / "map" / "memory.png"));
  // Reopen: the folder holds the same number of Gaussians and all keyframes.
  Mapper m(dir / "map", c, true);
  EXPECT_EQ(m.total_gaussians(), r["gaussians"]["total"].get<uint64_t>());
  EXPECT_EQ(m.keyframes().size(), 14u);  // 16 frames less 2 held out
  EXPECT_THROW(Mapper(dir / "map", c, false), Error);  // no silent overwrite
}

// The refinement after the last frame by default (mapper.final_iterations -1): one step a keyframe, in
// either pacing, and under fixed pacing at least four keyframes' steps (a map of few keyframes: new
// Gaussians need about a hundred steps). Under a real-time intake the steps come after the last frame has
// arrived, where they cost the intake nothing (an evicting map gains ~0.5 dB from them, bench/README.md).
nlohmann::json map_with_the_default_refinement(const std::filesystem::path& out, const std::string& pacing) {
  log::set_level(log::Level::Warn);
  const test::WallSequence seq(8);
  Config c = tiny_config();
  c.mapper.final_iterations = MapperConfig{}.final_iterations;
  c.mapper.pacing = pacing;
  c.mapper.speed = 4;  // anytime: the 8 frames arrive in 2 s
  nlohmann::json r = run_mapping(options(out, c), seq);
  EXPECT_TRUE(r.contains("refinement")) << r.dump(1);
  if (r.contains("refinement") && pacing == "anytime") {
    EXPECT_EQ(r["refinement"]["steps"], r["keyframes"]);
  }
  return r;
}

TEST(MappingRun, FixedPacingRefinesFourKeyframesStepsAtLeastByDefault) {
  test::TempDir dir;
  const auto r = map_with_the_default_refinement(dir / "map", "fixed");
  const uint64_t keyframes = r["keyframes"];
  EXPECT_EQ(keyframes, 7u);  // 8 frames less 1 held out
  const uint64_t per_keyframe = tiny_config().mapper.iterations_per_keyframe;
  ASSERT_GT(4 * per_keyframe, keyframes);  // so the floor, not one step a keyframe, decides
  EXPECT_EQ(r["refinement"]["steps"].get<uint64_t>(), 4 * per_keyframe);
  EXPECT_EQ(r["iterations"].get<uint64_t>(), keyframes * per_keyframe + 4 * per_keyframe);
}

TEST(MappingRun, AnytimePacingRefinesOneStepAKeyframeByDefault) {
  test::TempDir dir;
  EXPECT_GT(map_with_the_default_refinement(dir / "map", "anytime")["keyframes"].get<uint64_t>(), 0u);
}

namespace {
// 6 m of wall over 1 m chunks under a budget of 1000 Gaussians: the map streams through it.
const test::WallSequence& long_wall() {
  static const test::WallSequence seq(24, 64, 48, 0.25);
  return seq;
}
Config under_small_budget() {
  Config c = tiny_config();
  c.store.chunk_size = 0.5;
  c.residency.budget_gaussians = 1000;
  return c;
}
}  // namespace

// Under a budget the refinement streams the map through it: the report gives its own chunk I/O
// (a part of the run's) and where its steps' time went.
TEST(MappingRun, TheRefinementReportsItsOwnChunkIoUnderABudget) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence& seq = long_wall();
  Config c = under_small_budget();
  c.mapper.final_iterations = 40;
  const auto r = run_mapping(options(dir / "map", c), seq);
  ASSERT_TRUE(r.contains("refinement")) << r.dump(1);
  const auto& io = r["refinement"]["chunk_io"];
  const uint64_t loads = io["pool_loads"], all_loads = r["chunk_io"]["pool_loads"];
  EXPECT_GT(loads, 0u);
  EXPECT_LT(loads, all_loads);  // the drive loaded chunks too
  EXPECT_GT(io["evictions_dirty"].get<uint64_t>(), 0u);
  EXPECT_LE(io["take_ms"].get<double>(), io["loading_ms"].get<double>());
  EXPECT_LE(io["upload_ms"].get<double>(), io["loading_ms"].get<double>());
  EXPECT_LE(io["evict_copy_ms"].get<double>(), io["evicting_ms"].get<double>());
  EXPECT_LE(io["loading_ms"].get<double>(), r["chunk_io"]["loading_ms"].get<double>());
  const auto& steps = r["refinement"]["step_ms"];
  EXPECT_GT(steps["mean"].get<double>(), 0.0);
  EXPECT_LE(steps["pin"].get<double>(), steps["mean"].get<double>());
}

// A map refined in several groups (a budget below the map) gets refinement_group_steps a group by
// default, up to 16 a keyframe and the drive's own steps: one step a keyframe gave each group a single
// short visit.
TEST(MappingRun, UnderABudgetTheDefaultRefinementGivesEveryGroupItsSteps) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  Config c = under_small_budget();
  c.mapper.final_iterations = MapperConfig{}.final_iterations;
  c.mapper.iterations_per_keyframe = 3;  // so that the fixed pacing's least (12) does not decide
  const auto r = run_mapping(options(dir / "map", c), long_wall());
  ASSERT_TRUE(r.contains("refinement")) << r.dump(1);
  const uint64_t keyframes = r["keyframes"], groups = r["refinement"]["groups"], steps = r["refinement"]["steps"];
  const uint64_t per_group = uint64_t(c.mapper.refinement_group_steps);
  EXPECT_GT(groups, 1u);
  EXPECT_EQ(steps, std::min({groups * per_group, kMaxRefinementStepsPerKeyframe * keyframes, 3 * keyframes}));
  EXPECT_GT(steps, keyframes);
  EXPECT_EQ(r["iterations"].get<uint64_t>(), 3 * keyframes + steps);
}

TEST(MappingRun, ResidentGaussiansNeverExceedTheBudget) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence& seq = long_wall();
  Config c = under_small_budget();
  c.residency.eviction_hysteresis = 0.1;
  c.mapper.final_iterations = 0;
  const auto r = run_mapping(options(dir / "map", c), seq);
  const uint64_t total = r["gaussians"]["total"], peak = r["gaussians"]["peak_resident"];
  std::printf("budget 1000: peak resident %llu, total %llu, loads %llu, saves %llu, PSNR %.2f\n",
              (unsigned long long)peak, (unsigned long long)total,
              (unsigned long long)r["chunk_io"]["loads"].get<uint64_t>(),
              (unsigned long long)r["chunk_io"]["saves"].get<uint64_t>(), r["held_out"]["mean_psnr"].get<double>());
  EXPECT_LE(peak, 1000u);
  EXPECT_GT(total, 2u * 1000u);
  EXPECT_GT(r["chunk_io"]["loads"].get<uint64_t>(), 0u);

  // The timeline ends where the report does: after the final checkpoint, whose wait the plot's
  // I/O share must include.
  const auto rows = read_text_table(dir / "map" / "timeline.csv", true);
  ASSERT_GE(rows.size(), 2u);
  const std::vector<std::string>& header = rows.front().tokens;
  auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    EXPECT_NE(it, header.end()) << name;
    return it == header.end() ? -1.0 : rows.back().number_at(size_t(it - header.begin()));
  };
  const double mapping_s = r["time"]["mapping_s"], wait_ms = r["time"]["io_wait_ms"];
  EXPECT_NEAR(column("seconds"), mapping_s, 1e-4 * mapping_s);
  EXPECT_NEAR(column("io_wait_ms"), wait_ms, 1e-4 * wait_ms + 1e-3);
  EXPECT_GT(wait_ms, 0.0);
  EXPECT_NEAR(r["time"]["io_wait_share"].get<double>(), wait_ms / 1000.0 / mapping_s, 1e-9);
}

TEST(MappingRun, InCoreComparisonStopsWhereTheMapOutgrowsTheBudget) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  const test::WallSequence seq(24, 64, 48, 0.25);
  Config c = tiny_config();
  c.store.chunk_size = 0.5;
  c.residency.budget_gaussians = 1000;
  c.mapper.final_iterations = 0;
  c.mapper.in_core_only = true;
  const auto r = run_mapping(options(dir / "map", c), seq);
  ASSERT_TRUE(r.contains("stopped")) << r.dump(1);
  const size_t stop = r["stopped"]["frame"];
  EXPECT_LT(stop, 23u);
  EXPECT_GT(r["gaussians"]["total"].get<uint64_t>(), 1000u);
  EXPECT_EQ(r["chunk_io"]["loads"].get<uint64_t>(), 0u);  // nothing ever left memory
  EXPECT_EQ(r["chunk_io"]["evictions_dirty"].get<uint64_t>() + r["chunk_io"]["evictions_clean"].get<uint64_t>(), 0u);
  // Only the frames the map covers are scored: held-out frames are 7, 15, 23.
  EXPECT_EQ(r["held_out"]["count"].get<size_t>(), size_t((stop + 1) / 8));
}

// Run by MappingRun.ResumesAfterSigkill in a child process (the parent kills it halfway).
TEST(MappingRunChild, MapsUntilKilled) {
  const char* out = std::getenv("CHUNGS_TEST_CHILD_MAP");
  if (!out) GTEST_SKIP() << "only run as the child of MappingRun.ResumesAfterSigkill";
  log::set_level(log::Level::Warn);
  const test::WallSequence seq(24);
  Config c = tiny_config();
  c.mapper.iterations_per_keyframe = 25;  // slow enough to be killed halfway
  c.mapper.checkpoint_every = 1;
  run_mapping(options(out, c), seq);
}

TEST(MappingRun, ResumesAfterSigkill) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const std::string map = (dir / "map").string();
  const std::string env = "CHUNGS_TEST_CHILD_MAP=" + map;
  std::string filter = "--gtest_filter=MappingRunChild.MapsUntilKilled";
  char* argv[] = {const_cast<char*>("test_mapping"), filter.data(), nullptr};
  std::vector<char*> envp;
  for (char** e = environ; *e; ++e) envp.push_back(*e);
  envp.push_back(const_cast<char*>(env.c_str()));
  envp.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv, envp.data()), 0);
  // Kill it once a checkpoint past frame 12 exists.
  size_t killed_at = 0;
  for (int k = 0; k < 1200 && !killed_at; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    try {
      if (!std::filesystem::exists(dir / "map" / "run_state.json")) continue;
      const auto s = read_json_file(dir / "map" / "run_state.json");
      if (s.value("next_frame", size_t(0)) >= 8) killed_at = s["next_frame"];
    } catch (const Error&) {
    }
  }
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_GT(killed_at, 0u) << "the child never reached frame 8";
  ASSERT_TRUE(WIFSIGNALED(status)) << "the child finished before it was killed";
  uint64_t at_kill = 0;
  {
    Config c = tiny_config();
    Mapper m(dir / "map", c, true);
    at_kill = m.total_gaussians();
    EXPECT_GT(at_kill, 0u);
  }
  const test::WallSequence seq(24);
  Config c = tiny_config();
  c.mapper.iterations_per_keyframe = 25;
  c.mapper.checkpoint_every = 1;
  RunOptions o = options(dir / "map", c);
  o.resume = true;
  const auto r = run_mapping(o, seq);
  std::printf("killed after frame %zu with %llu Gaussians; resumed to %llu Gaussians, %zu keyframes, PSNR %.2f\n",
              killed_at, (unsigned long long)at_kill, (unsigned long long)r["gaussians"]["total"].get<uint64_t>(),
              r["keyframes"].get<size_t>(), r["held_out"]["mean_psnr"].get<double>());
  EXPECT_EQ(r["keyframes"].get<size_t>(), 21u);  // 24 frames less 3 held out, each exactly once
  EXPECT_GE(r["gaussians"]["total"].get<uint64_t>(), at_kill / 2);
  EXPECT_GT(r["held_out"]["mean_psnr"].get<double>(), 18.0);
  const auto s = read_json_file(dir / "map" / "run_state.json");
  EXPECT_TRUE(s["finished"].get<bool>());
}

}  // namespace
}  // namespace chungs
