// `run --mono-depth-model FILE` and mapper.mono_depth_model (issue 25): a model that cannot be used is
// refused with one line naming the flag or key and the file, before the map folder is touched; a usable
// one gives a tracked monocular run's plane sweep its prior.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;
using chungs::test::run_shell;
namespace fs = std::filesystem;

namespace {

const std::string kRun = "run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --max-frames 4 "
                         "--iterations 1 --input mono";

// A tiny model written by tests/depth/make_tiny_depth_model.py into `file`; false (and why) when
// python3-onnx is missing, so the caller skips.
bool write_tiny_model(const fs::path& file, std::string& why) {
  const std::string python = "/usr/bin/python3";
  if (run_shell(python + " -c 'import onnx'").code != 0) {
    why = "python3-onnx is not installed (apt-get install python3-onnx): no test model";
    return false;
  }
  const fs::path generator = fs::path(__FILE__).parent_path().parent_path() / "depth" / "make_tiny_depth_model.py";
  const auto r = run_shell(python + " " + generator.string() + " --kind dynamic --out " + file.string());
  EXPECT_EQ(r.code, 0) << r.out;
  why = "the model generator failed: " + r.out;
  return r.code == 0;
}

}  // namespace

TEST(CliMonoDepthModel, BadModelIsRefusedBeforeTheFolderIsTouched) {
  chungs::test::TempDir dir;
  const fs::path map = dir / "map";
  auto r = run_cli(kRun + " --out " + map.string() + " --mono-depth-model " + (dir / "absent.onnx").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--mono-depth-model: " + (dir / "absent.onnx").string() + ": the depth model does not exist"),
            std::string::npos)
      << r.out;
  EXPECT_FALSE(fs::exists(map));

  // pareto takes run's mapping flags, this one too.
  r = run_cli("pareto --dataset synth-street:length=12,width=160,height=48,seed=2 --input mono --out " + map.string() +
              " --mono-depth-model " + (dir / "absent.onnx").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--mono-depth-model: " + (dir / "absent.onnx").string()), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(map));

  r = run_cli(kRun + " --out " + map.string() + " --mono-depth-model ''");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--mono-depth-model must be an ONNX model file"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(map));

  // From a configuration file: the key is named.
  std::ofstream(dir / "cfg.yaml") << "mapper:\n  mono_depth_model: " << (dir / "absent.onnx").string() << "\n";
  r = run_cli(kRun + " --out " + map.string() + " --config " + (dir / "cfg.yaml").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("mapper.mono_depth_model: " + (dir / "absent.onnx").string()), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(map));
}

TEST(CliMonoDepthModel, WithoutTheRuntimeTheErrorSaysWhatToInstall) {
  chungs::test::TempDir dir;
  std::ofstream(dir / "model.onnx") << "not checked before the runtime is found";
  const fs::path map = dir / "map";
  auto r = run_shell("CHUNGS_ONNXRUNTIME=" + (dir / "nowhere" / "libonnxruntime.so.1").string() + " " + CHUNGS_CLI +
                     " " + kRun + " --out " + map.string() + " --mono-depth-model " + (dir / "model.onnx").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--mono-depth-model: " + (dir / "model.onnx").string() +
                       ": ONNX Runtime named by CHUNGS_ONNXRUNTIME cannot be used"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("npm install --ignore-scripts onnxruntime-node@"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(map));
}

TEST(CliMonoDepthModel, InfoConfigListsTheKey) {
  auto r = run_cli("info --config");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("mono_depth_model:"), std::string::npos) << r.out;
}

// End to end: a tracked monocular run with a (tiny, generated) model uses it as the plane sweep's prior,
// reports it, and its trajectory says it is monocular, so eval ate aligns it with Sim(3).
TEST(CliMonoDepthModel, TrackedMonoRunUsesTheModelAsThePrior) {
  chungs::test::TempDir dir;
  std::string why;
  if (!write_tiny_model(dir / "tiny.onnx", why)) {
    if (::testing::Test::HasFailure()) return;
    GTEST_SKIP() << why;
  }
  chungs::test::CliResult r;
  const fs::path map = dir / "map";
  r = run_cli("-q run --dataset synth-street:length=30,width=320,height=96,seed=1 --input mono --poses track "
              "--max-frames 30 --device cpu --out " + map.string() + " --mono-depth-model " + (dir / "tiny.onnx").string());
  if (r.code != 0 && r.out.find("install ONNX Runtime's library") != std::string::npos)
    GTEST_SKIP() << "no ONNX Runtime: " << r.out;
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream f(map / "report.json");
  const auto rep = nlohmann::json::parse(f);
  EXPECT_EQ(rep["multiview"]["prior_source"], "learned depth") << rep["multiview"].dump();
  const auto& ld = rep["learned_depth"];
  ASSERT_TRUE(ld.is_object()) << rep.dump();
  EXPECT_NE(ld["model"].get<std::string>().find("tiny.onnx"), std::string::npos);
  // Every sweep asked the source once: aligned, or handed to the densified map points.
  EXPECT_EQ(ld["aligned_keyframes"].get<size_t>() + ld["fallback_keyframes"].get<size_t>(),
            rep["multiview"]["swept"].get<size_t>())
      << rep["multiview"].dump() << ld.dump();
  EXPECT_GT(rep["multiview"]["swept"].get<size_t>(), 0u);
  r = run_cli("eval ate --gt " + (map / "trajectory.txt").string() + " --est " + (map / "trajectory.txt").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("ATE (sim3 alignment"), std::string::npos) << r.out;
}

// Depth from stereo (or a sensor) needs no prior: the model is loaded (and so checked) but not used,
// and the run says so.
TEST(CliMonoDepthModel, StereoRunSaysTheModelIsNotUsed) {
  chungs::test::TempDir dir;
  std::string why;
  if (!write_tiny_model(dir / "tiny.onnx", why)) {
    if (::testing::Test::HasFailure()) return;
    GTEST_SKIP() << why;
  }
  chungs::test::CliResult r;
  r = run_cli("run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --max-frames 4 "
              "--iterations 1 --out " + (dir / "map").string() + " --mono-depth-model " + (dir / "tiny.onnx").string());
  if (r.code != 0 && r.out.find("install ONNX Runtime's library") != std::string::npos)
    GTEST_SKIP() << "no ONNX Runtime: " << r.out;
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("this run's depth is stereo, so the model is not used"), std::string::npos) << r.out;
  std::ifstream f(dir / "map" / "report.json");
  EXPECT_FALSE(nlohmann::json::parse(f).contains("learned_depth"));
}
