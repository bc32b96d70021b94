#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;

TEST(Cli, InfoPrintsVersionAndBuild) {
  auto r = run_cli("info");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("diskchungs "), std::string::npos);
  EXPECT_NE(r.out.find("cuda"), std::string::npos);
}

TEST(Cli, UnknownDatasetKindIsOneLineErrorWithNonZeroExit) {
  auto r = run_cli("inspect foo:/nowhere");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("foo"), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
}

TEST(Cli, MissingDatasetFolderNamesThePath) {
  auto r = run_cli("inspect kitti:/nowhere/seq");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("/nowhere/seq"), std::string::npos) << r.out;
}

TEST(Cli, InspectsRealKitti) {
  CHUNGS_REQUIRE_DATA("kitti_seq1");
  auto r = run_cli("inspect --json kitti:" + chungs::test::shared_data("kitti_seq1").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"frames\": 51"), std::string::npos) << r.out;
}

// 3DMatch's excerpt holds frames 0, 1, 2, 116 and 422: inspect says where frames are missing (the tracker
// coasts over such a gap), and says nothing of gaps for a sequence without them.
// A trajectory that cannot be written is refused before the tracking, not after every frame of it.
TEST(Cli, TrackRefusesAnOutputItCannotWriteBeforeTracking) {
  chungs::test::TempDir dir;
  std::ofstream(dir / "afile") << "x\n";
  const std::string street = "track --dataset synth-street:length=30,width=160,height=48 --out ";
  auto r = run_cli(street + (dir / "afile" / "t.txt").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("t.txt: cannot make the folder " + (dir / "afile").string() + " for the trajectory"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("tracking:"), std::string::npos) << "it tracked first\n" << r.out;
  std::filesystem::create_directories(dir / "folder");
  r = run_cli(street + (dir / "folder").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("folder: is a folder, not a file for the trajectory"), std::string::npos) << r.out;
}

// inspect took folders only: the synthetic street every other command takes was an "unknown kind".
TEST(Cli, InspectsTheSyntheticStreetAsOtherCommandsTakeIt) {
  const std::string spec = "synth-street:length=300,width=160,height=48,seed=1";
  auto r = run_cli("inspect " + spec);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("kind:            synth-street"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("path:            generated from " + spec), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frames:          301"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("gt path length:  299.9"), std::string::npos) << r.out;
  r = run_cli("inspect synth-street:length=30,width=0,height=48");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("image size 0x48 is out of range"), std::string::npos) << r.out;
}

TEST(Cli, InspectNamesTheLargestGapBetweenFrames) {
  CHUNGS_REQUIRE_DATA("3dmatch_seq01");
  CHUNGS_REQUIRE_DATA("kitti_seq1");
  auto r = run_cli("inspect 3dmatch:" + chungs::test::shared_data("3dmatch_seq01").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("the largest 10.200 s, between frames 3 and 4"), std::string::npos) << r.out;
  auto k = run_cli("inspect kitti:" + chungs::test::shared_data("kitti_seq1").string());
  ASSERT_EQ(k.code, 0) << k.out;
  EXPECT_EQ(k.out.find("gaps:"), std::string::npos) << k.out;
}

TEST(Cli, AnUnknownCommandIsNamedWithTheCommandsThereAre) {
  for (const std::string args : {"frobnicate", "-q frobnicate --out x"}) {
    auto r = run_cli(args);
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("unknown command 'frobnicate'"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("run"), std::string::npos) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  }
}

TEST(Cli, AnUnknownKindOfACommandIsNamedWithTheKindsThereAre) {
  // `synth castle` used to say only that a subcommand is required.
  for (const auto& [args, expected] : std::vector<std::pair<std::string, std::string>>{
           {"synth castle --out x",
            "unknown synth command 'castle' (synth commands: room, street, mesh, check-office0)"},
           {"-q eval speed --gt a --est b", "unknown eval command 'speed' (eval commands: ate, images, depth)"}}) {
    auto r = run_cli(args);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find(expected), std::string::npos) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  }
}

// Four frames hold none out (every 8th is): the run says so, and prints no 0 dB score.
TEST(Cli, ARunWithoutHeldOutFramesSaysSoInsteadOfAScore) {
  chungs::test::TempDir dir;
  auto r = run_cli("run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --max-frames 4 "
                   "--iterations 1 --final-iterations 0 --out " + (dir / "map").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("held-out: none (every 8th frame is held out and the run has 4 frames)"), std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("held-out PSNR 0.000"), std::string::npos) << r.out;
  // Fixed pacing names its steps, not the real-time floor; a few metres give totals, not rates per 100 m.
  EXPECT_NE(r.out.find(", fixed at 1), "), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("floor"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" pruned over "), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("per 100 m"), std::string::npos) << r.out;
  std::ifstream f(dir / "map" / "report.json");
  const auto j = nlohmann::json::parse(f, nullptr, false);
  ASSERT_TRUE(j.contains("held_out")) << r.out;
  EXPECT_EQ(j["held_out"]["count"].get<size_t>(), 0u);
  EXPECT_TRUE(j["held_out"].contains("none"));
}
