// `run --mono-depth-model FILE` and mapper.mono_depth_model (issue 25): a model that cannot be used is
// refused with one line naming the flag or key and the file, before the map folder is touched.
#include <gtest/gtest.h>

#include <fstream>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;
using chungs::test::run_shell;
namespace fs = std::filesystem;

namespace {

const std::string kRun = "run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --max-frames 4 "
                         "--iterations 1 --input mono";

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
