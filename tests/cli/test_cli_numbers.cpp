// Numbers typed on the command line: out of range (zero where it used to mean "default", negative,
// NaN, infinite) is refused with the flag named and a non-zero exit, before anything is written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

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
  const std::string run =
      "run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --out " + out.string() +
      " ";
  for (const auto& [args, flag] :
       std::vector<std::pair<std::string, std::string>>{{"--resolution 0", "--resolution"},
                                                        {"--resolution nan", "--resolution"},
                                                        {"--resolution 1.5", "--resolution"},
                                                        {"--budget 0", "--budget"},
                                                        {"--budget -3", "--budget"},
                                                        {"--chunk-size -1", "--chunk-size"},
                                                        {"--chunk-size 1e-9", "--chunk-size"},
                                                        {"--iterations -5", "--iterations"},
                                                        {"--final-iterations -1", "--final-iterations"},
                                                        {"--speed inf", "--speed"},
                                                        {"--speed 0", "--speed"},
                                                        {"--speed 1e-320", "--speed"},
                                                        {"--speed 0.001", "--speed"},
                                                        {"--fill-depth -2", "--fill-depth"},
                                                        {"--max-frames 0", "--max-frames"},
                                                        {"--max-frames -5", "--max-frames"}})
    expect_refused(run + args, flag, out);
}

// --speed is the intake rate of anytime pacing: under fixed pacing it did nothing, without a word.
TEST(CliNumbers, ASpeedUnderFixedPacingIsSaidToChangeNothing) {
  chungs::test::TempDir dir;
  const std::string run = "run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --no-eval "
                          "--iterations 2 --final-iterations 0 --speed 2 --out ";
  auto r = run_cli(run + (dir / "fixed").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("[warning] --speed 2 sets the intake rate of anytime pacing and changes nothing under fixed"),
            std::string::npos)
      << r.out;
  r = run_cli(run + (dir / "anytime").string() + " --pacing anytime");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("--speed 2 sets the intake rate"), std::string::npos) << r.out;
}

TEST(CliNumbers, RunRefusesImagesTooSmallToMapBeforeWritingAnything) {
  chungs::test::TempDir dir;
  const auto out = dir / "map";
  auto r = run_cli(
      "run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --resolution 0.1 "
      "--out " +
      out.string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("are 16x5, below the 16x16"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliNumbers, TrackingRefusesTinyImagesInsteadOfAborting) {
  // 1x1 stereo images: OpenCV threw inside an OpenMP region and the process aborted (exit 134).
  chungs::test::TempDir dir;
  auto r = run_cli("synth street --out " + (dir / "seq").string() +
                   " --frames 3 --width 1 --height 1 --length-m 10");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_cli("track --dataset kitti:" + (dir / "seq").string() + " --out " + (dir / "t.txt").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("is 1x1, below the 32x32"), std::string::npos) << r.out;
}

// Images too small for any feature: the tracker never starts. `track` said only that ATE matched 0 poses
// (after writing an empty trajectory), `run --poses track` that no frame became a keyframe.
TEST(CliNumbers, ATrackerThatNeverStartsSaysWhyAndWritesNoTrajectory) {
  chungs::test::TempDir dir;
  const std::string street = "synth-street:length=20,width=64,height=32";
  auto r = run_cli("-q track --dataset " + street + " --out " + (dir / "t.txt").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("the tracker never started: a frame needs 50 features with depth"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(64x32 images)"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "t.txt"));
  r = run_cli("-q run --dataset " + street + " --poses track --out " + (dir / "map").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("no frame with a pose became a keyframe; the tracker never started"), std::string::npos)
      << r.out;
  // Nothing was committed (the run ended before its first checkpoint): it says so, and the same command
  // into the folder starts afresh rather than being refused as a map.
  EXPECT_NE(r.out.find("nothing was committed to " + (dir / "map").string() + " (a new run there starts afresh)"),
            std::string::npos) << r.out;
  r = run_cli("-q run --dataset " + street + " --poses track --out " + (dir / "map").string());
  EXPECT_EQ(r.out.find("already holds a map"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no frame with a pose became a keyframe"), std::string::npos) << r.out;
}

TEST(CliNumbers, DemoRefusesOutOfRangeValuesNamingTheFlag) {
  chungs::test::TempDir dir;
  const auto out = dir / "demo";
  const std::string demo = "demo --out " + out.string() + " ";
  for (const auto& [args, flag] :
       std::vector<std::pair<std::string, std::string>>{{"--budget 0", "--budget"},
                                                        {"--budget -2", "--budget"},
                                                        {"--resolution 0", "--resolution"},
                                                        {"--chunk-size 0", "--chunk-size"},
                                                        {"--chunk-size 1e-9", "--chunk-size"},
                                                        {"--iterations -1", "--iterations"},
                                                        {"--scene room --frames 0", "--frames"}})
    expect_refused(demo + args, flag, out);
}

TEST(CliNumbers, SynthRefusesOutOfRangeValuesNamingTheFlag) {
  // --frames -3 wrapped to 2^64 - 3 (2.5 GB, then bad_alloc), --width 100000 ended in bad_alloc, and
  // --seed -1, --length-m inf, --every -1 or --rate 0 were taken without a word.
  chungs::test::TempDir dir;
  const auto out = dir / "seq";
  {
    std::ofstream(dir / "m.ply")
        << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
           "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
           "end_header\n-1 -1 0\n1 -1 0\n0 1 0\n3 0 1 2\n";
    std::ofstream(dir / "t.txt") << "0 0 0 -2 0 0 0 1\n";
  }
  const std::string room = "synth room --out " + out.string() + " --width 32 --height 32 ";
  const std::string street = "synth street --out " + out.string() + " --width 32 --height 32 ";
  const std::string mesh = "synth mesh --mesh " + (dir / "m.ply").string() + " --traj " +
                           (dir / "t.txt").string() + " --intrinsics 50,50,16,16,32,32 --out " +
                           out.string() + " ";
  for (const auto& [args, flag] : std::vector<std::pair<std::string, std::string>>{
           {room + "--frames -3", "--frames"},
           {room + "--frames 0", "--frames"},
           {"synth room --out " + out.string() + " --frames 1 --height 32 --width 100000", "--width"},
           {"synth room --out " + out.string() + " --frames 1 --width 32 --height 0", "--height"},
           {room + "--frames 2 --layout kitti --baseline inf", "--baseline"},
           {street + "--frames -1 --length-m 20", "--frames"},
           {street + "--frames 2 --length-m inf", "--length-m"},
           {street + "--frames 2 --length-m 1e308", "--length-m"},
           {mesh + "--every -1", "--every"},
           {mesh + "--rate 0", "--rate"},
           {mesh + "--rate nan", "--rate"},
           {mesh + "--baseline -1", "--baseline"},
           {mesh + "--frames -1", "--frames"}})
    expect_refused(args, flag, out);
  auto r = run_cli(room + "--frames 2 --seed -1");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("--seed"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliNumbers, TrackRefusesOutOfRangeValuesNamingTheFlag) {
  // A typed -1 meant "all frames" or "the default" before; NaN and infinite baselines were ignored.
  chungs::test::TempDir dir;
  auto r = run_cli("synth room --out " + (dir / "room").string() + " --frames 3 --width 64 --height 48");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string track =
      "track --dataset tum:" + (dir / "room").string() + " --out " + (dir / "t.txt").string() + " ";
  for (const auto& [args, flag] :
       std::vector<std::pair<std::string, std::string>>{{"--max-frames -1", "--max-frames"},
                                                        {"--kf-min-interval -5", "--kf-min-interval"},
                                                        {"--kf-max-interval -1", "--kf-max-interval"},
                                                        {"--rgbd-baseline nan", "--rgbd-baseline"},
                                                        {"--rgbd-baseline inf", "--rgbd-baseline"},
                                                        {"--rgbd-baseline -1", "--rgbd-baseline"}})
    expect_refused(track + args, flag, dir / "t.txt");
}

TEST(CliNumbers, EvalDemoAndRunNameTheFlagAtFault) {
  chungs::test::TempDir dir;
  std::ofstream(dir / "t.txt")
      << "0 0 0 0 0 0 0 1\n0.1 1 0 0 0 0 0 1\n0.2 2 0 0 0 0 0 1\n0.3 3 0 0 0 0 0 1\n";
  const std::string ate =
      "eval ate --gt " + (dir / "t.txt").string() + " --est " + (dir / "t.txt").string() + " ";
  for (const auto& [args, flag] : std::vector<std::pair<std::string, std::string>>{
           {ate + "--max-dt -1", "--max-dt"},
           {ate + "--max-dt nan", "--max-dt"},
           {ate + "--rpe-delta 0", "--rpe-delta"},
           {"demo --out " + (dir / "demo").string() + " --seed -1", "--seed"}})
    expect_refused(args, flag, dir / "demo");
  // An empty --pacing was taken as not given.
  auto r = run_cli("run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --out " +
                   (dir / "map").string() + " --pacing ''");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("pacing must be fixed or anytime, got ''"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "map"));
}

TEST(CliNumbers, RenderAndExportRefuseOutOfRangeValuesNamingTheFlag) {
  // All were taken: --budget 0 and --resolution 0 as "the default", --resolution nan as 1, --stride -1
  // wrapped to 2^64 - 1 (one view), --budget -1 ended in "cannot create std::vector larger than
  // max_size()", and a box with NaN, infinite or swapped corners exported 0 Gaussians without a word.
  // The flags are checked before the map is opened, so no map is needed here.
  chungs::test::TempDir dir;
  const auto out = dir / "out";
  const std::string render =
      "render --map " + (dir / "map").string() + " --poses t.txt --out " + out.string() + " ";
  const std::string ply = "export --map " + (dir / "map").string() + " --out " + out.string() + " ";
  for (const auto& [args, flag] :
       std::vector<std::pair<std::string, std::string>>{{render + "--budget 0", "--budget"},
                                                        {render + "--budget -1", "--budget"},
                                                        {render + "--resolution 0", "--resolution"},
                                                        {render + "--resolution nan", "--resolution"},
                                                        {render + "--resolution 2", "--resolution"},
                                                        {render + "--stride 0", "--stride"},
                                                        {render + "--stride -1", "--stride"},
                                                        {ply + "--box nan 0 0 1 1 1", "--box"},
                                                        {ply + "--box 0 0 0 inf 1 1", "--box"},
                                                        {ply + "--box 0 0 0 -1 1 1", "--box"}})
    expect_refused(args, flag, out);
}

TEST(CliNumbers, WholeNumbersAreReadAsWrittenOrRefused) {
  // CLI11 kept what strtoll / strtoull returned: a number past 64 bits became the largest one (run then
  // refused "9223372036854775807", which nobody typed; synth took it as a seed), -1 became 2^64 - 1 for
  // an unsigned flag, and a leading zero made a number octal (--budget 010 was 8).
  chungs::test::TempDir dir;
  const auto out = dir / "out";
  const std::string run =
      "run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --out " + out.string() +
      " ";
  const std::string street = "synth street --out " + out.string() + " --width 32 --height 32 --frames 2 ";
  for (const auto& [args, flag] : std::vector<std::pair<std::string, std::string>>{
           {run + "--budget 99999999999999999999", "--budget"},
           {run + "--budget 10000000000000000000", "--budget"},
           {run + "--budget 010", "--budget"},
           {run + "--budget 0x100", "--budget"},
           {run + "--max-frames 99999999999999999999", "--max-frames"},
           {street + "--seed 99999999999999999999", "--seed"},
           {street + "--seed 18446744073709551616", "--seed"},
           {street + "--seed -1", "--seed"},
           {"view --port 99999999999999999999 " + (dir / "map").string(), "--port"},
           {"render --map " + (dir / "map").string() + " --poses t.txt --out " + out.string() +
                " --stride 99999999999999999999",
            "--stride"}}) {
    auto r = run_cli(args);
    EXPECT_NE(r.code, 0) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("error: " + flag + " must be a whole number"), std::string::npos) << args << "\n"
                                                                                           << r.out;
    // Named as typed, not as what the C library made of it (strtoll clamps to 9223372036854775807).
    const size_t at = args.find(flag + " ") + flag.size() + 1;
    const std::string typed = args.substr(at, args.find(' ', at) - at);
    EXPECT_NE(r.out.find(", got " + typed), std::string::npos) << args << "\n" << r.out;
    EXPECT_FALSE(std::filesystem::exists(out)) << args << " wrote " << out;
  }
  // A 32-bit flag: CLI11 refused these itself ("Could not convert: --iterations = 3000000000", exit 104); now
  // the same words as above, with the flag's range.
  for (const auto& [args, says] : std::vector<std::pair<std::string, std::string>>{
           {run + "--iterations 3000000000",
            "--iterations must be a whole number at most 2147483647, got 3000000000"},
           {run + "--iterations 99999999999999999999",
            "--iterations must be a whole number at most 2147483647, got 99999999999999999999"},
           {run + "--iterations -3000000000",
            "--iterations must be a whole number at least -2147483648, got -3000000000"},
           {run + "--iterations ten", "--iterations must be a whole number written in decimal, got ten"},
           {run + "--budget ten", "--budget must be a whole number written in decimal, got ten"},
           {run + "--iterations 0x10", "--iterations must be a whole number written in decimal, got 0x10"},
           {run + "--max-frames 0x10", "--max-frames must be a whole number written in decimal, got 0x10"},
           {run + "--max-frames 99999999999999999999",
            "--max-frames must be a whole number at most 9223372036854775807, got 99999999999999999999"},
           // The end the number passed, not a range from a negative number that no budget could take.
           {run + "--budget 99999999999999999999",
            "--budget must be a whole number at most 9223372036854775807, got 99999999999999999999"},
           {run + "--budget -99999999999999999999",
            "--budget must be a whole number at least -9223372036854775808, got -99999999999999999999"},
           {run + "--speed fast", "--speed must be a number, got fast"},
           {"synth street --out " + out.string() + " --width 99999999999",
            "--width must be a whole number at most 2147483647"},
           // A flag of three values names the one at fault (it said "got 99999999999,0,0", "written in decimal").
           {"export --map " + (dir / "map").string() + " --out " + out.string() + " --chunk 0 99999999999 0",
            "--chunk must be a whole number at most 2147483647, got 99999999999\n"},
           {"export --map " + (dir / "map").string() + " --out " + out.string() + " --chunk 0 0 x",
            "--chunk must be a whole number written in decimal, got x\n"}}) {
    auto r = run_cli(args);
    EXPECT_EQ(r.code, 1) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("diskchungs: error: " + says), std::string::npos) << args << "\n" << r.out;
    EXPECT_EQ(r.out.find("Could not convert"), std::string::npos) << args << "\n" << r.out;
    EXPECT_FALSE(std::filesystem::exists(out)) << args << " wrote " << out;
  }
  // The largest seed there is, and a '+', are numbers as written.
  auto r = run_cli(street + "--length-m 10 --seed 18446744073709551615");
  EXPECT_EQ(r.code, 0) << r.out;
  std::filesystem::remove_all(out);
  r = run_cli(street + "--length-m 10 --seed +7");
  EXPECT_EQ(r.code, 0) << r.out;
}

}  // namespace
