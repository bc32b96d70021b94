// Numbers typed on the command line: out of range (zero where it used to mean "default", negative,
// NaN, infinite) is refused with the flag named and a non-zero exit, before anything is written.
#include <gtest/gtest.h>

#include <filesystem>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;

namespace {

void expect_refused(const std::string& command, const std::string& flag, const std::filesystem::path& out) {
  auto r = run_cli(command);
  EXPECT_NE(r.code, 0) << command << "\n" << r.out;
  EXPECT_NE(r.out.find("error: " + flag + " must be"), std::string::npos) << command << "\n" << r.out;
  EXPECT_FALSE(std::filesystem::exists(out)) << command << " wrote " << out;
}

TEST(CliNumbers, RunRefusesOutOfRangeValuesNamingTheFlag) {
  chungs::test::TempDir dir;
  const auto out = dir / "map";
  const std::string run = "run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --out " +
                          out.string() + " ";
  for (const auto& [args, flag] : std::vector<std::pair<std::string, std::string>>{
           {"--resolution 0", "--resolution"}, {"--resolution nan", "--resolution"},
           {"--resolution 1.5", "--resolution"}, {"--budget 0", "--budget"}, {"--budget -3", "--budget"},
           {"--chunk-size -1", "--chunk-size"}, {"--iterations -5", "--iterations"},
           {"--final-iterations -1", "--final-iterations"}, {"--speed inf", "--speed"}, {"--speed 0", "--speed"},
           {"--fill-depth -2", "--fill-depth"}, {"--max-frames 0", "--max-frames"},
           {"--max-frames -5", "--max-frames"}})
    expect_refused(run + args, flag, out);
}

TEST(CliNumbers, RunRefusesImagesTooSmallToMapBeforeWritingAnything) {
  chungs::test::TempDir dir;
  const auto out = dir / "map";
  auto r = run_cli("run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --resolution 0.1 "
                   "--out " + out.string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("are 16x5, below the 16x16"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliNumbers, TrackingRefusesTinyImagesInsteadOfAborting) {
  // 1x1 stereo images: OpenCV threw inside an OpenMP region and the process aborted (exit 134).
  chungs::test::TempDir dir;
  auto r = run_cli("synth street --out " + (dir / "seq").string() + " --frames 3 --width 1 --height 1 --length-m 10");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_cli("track --dataset kitti:" + (dir / "seq").string() + " --out " + (dir / "t.txt").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("is 1x1, below the 32x32"), std::string::npos) << r.out;
}

TEST(CliNumbers, DemoRefusesOutOfRangeValuesNamingTheFlag) {
  chungs::test::TempDir dir;
  const auto out = dir / "demo";
  const std::string demo = "demo --out " + out.string() + " ";
  for (const auto& [args, flag] : std::vector<std::pair<std::string, std::string>>{
           {"--budget 0", "--budget"}, {"--budget -2", "--budget"}, {"--resolution 0", "--resolution"},
           {"--chunk-size 0", "--chunk-size"}, {"--iterations -1", "--iterations"},
           {"--scene room --frames 0", "--frames"}})
    expect_refused(demo + args, flag, out);
}

}  // namespace
