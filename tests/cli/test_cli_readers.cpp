// export and render only read a map: a PLY or a render is never written inside the map folder, and a
// map with a listed chunk missing is refused with the file named instead of being "repaired" by the
// reader. Running out of memory ends as one line naming the command, like any other error.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/cli_support.hpp"
#include "png_bytes.hpp"
#include "test_support.hpp"

using chungs::test::read_all;
using chungs::test::run_cli;
namespace fs = std::filesystem;

namespace {


TEST(CliReaders, ExportNeverWritesIntoTheMapNorRepairsIt) {
  chungs::test::TempDir dir;
  const fs::path map = dir / "map";
  auto r = run_cli("-q run --dataset synth-street:length=30,width=160,height=48,seed=2 --device cpu --max-frames 12 "
                   "--no-eval --out " + map.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string manifest = read_all(map / "manifest.txt");

  r = run_cli("export --map " + map.string() + " --out " + (map / "manifest.txt").string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("inside the map folder"), std::string::npos) << r.out;
  EXPECT_EQ(read_all(map / "manifest.txt"), manifest);

  fs::path moved;
  for (const auto& e : fs::directory_iterator(map / "chunks")) {
    moved = e.path();
    break;
  }
  ASSERT_FALSE(moved.empty());
  fs::rename(moved, dir / "aside.chunk");
  r = run_cli("export --map " + map.string() + " --out " + (dir / "a.ply").string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(moved.filename().string()), std::string::npos) << r.out;
  EXPECT_EQ(read_all(map / "manifest.txt"), manifest);
  fs::rename(dir / "aside.chunk", moved);
  r = run_cli("export --map " + map.string() + " --out " + (dir / "b.ply").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(moved));  // the file that came back is still there
  EXPECT_EQ(read_all(map / "manifest.txt"), manifest);
}

TEST(CliReaders, RenderWritesBesideTheMapNeverIntoIt) {
  chungs::test::TempDir dir;
  const fs::path map = dir / "map";
  auto r = run_cli(
      "-q run --dataset synth-street:length=30,width=160,height=48,seed=2 --device cpu --max-frames 12 "
      "--no-eval --out " +
      map.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string poses = " --poses " + (map / "trajectory.txt").string() + " --stride 6";

  r = run_cli("-q render --map " + map.string() + poses);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(fs::exists(map / "render"));
  EXPECT_TRUE(fs::exists(dir / "map-renders" / "render_000000.png"));
  fs::remove_all(dir / "map-renders");
  r = run_cli("-q render --map " + map.string() + "/" + poses);  // a trailing slash names the same folder
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir / "map-renders" / "render_000000.png"));

  for (const fs::path& out : {map / "views", map, map / "chunks"}) {
    r = run_cli("render --map " + map.string() + poses + " --out " + out.string());
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("inside the map folder"), std::string::npos) << r.out;
  }
  EXPECT_FALSE(fs::exists(map / "views"));
  EXPECT_FALSE(fs::exists(map / "chunks" / "render_000000.png"));
}

TEST(CliBoundary, OutOfMemoryIsOneLineNamingTheCommand) {
  // A valid 8192x8192 RGBA PNG decodes to 256 MB; under a 200 MB address space its decode fails.
  chungs::test::TempDir dir;
  {
    std::ofstream f(dir / "big.png", std::ios::binary);
    f << chungs::test::png_of_zeros(8192, 8192, 6, 8192);
  }
  const std::string png = (dir / "big.png").string();
  auto r = chungs::test::run_cli_with_memory_limit(200, "-q eval images --ref " + png + " --test " + png);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("out of memory"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("eval images"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("big.png"), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
}

}  // namespace
