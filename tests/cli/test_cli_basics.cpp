#include <gtest/gtest.h>

#include <fstream>
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
