// export and render only read a map: a PLY is never written inside the map folder, and a map with a
// listed chunk missing is refused with the file named instead of being "repaired" by the reader.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;
namespace fs = std::filesystem;

namespace {

std::string read_all(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

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

}  // namespace
