// --resume on a map whose committed state files are missing: refused with the file named
// and a non-zero exit, and the folder's manifest and chunk files are left as they were (it used to
// restart at frame 0 on top of the map, or resume with no keyframes).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>
#include <vector>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::read_all;
using chungs::test::run_cli;
namespace fs = std::filesystem;

namespace {

const std::string kDataset = "synth-street:length=30,width=160,height=48,seed=2";


// Names and sizes of every file under the folder, for "nothing changed".
std::string listing(const fs::path& dir) {
  std::string out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out += e.path().string() + " " + std::to_string(e.file_size()) + "\n";
  return out;
}

fs::path small_map(const fs::path& dir) {
  const fs::path map = dir / "map";
  auto r = run_cli("-q run --dataset " + kDataset + " --device cpu --max-frames 12 --no-eval --out " + map.string());
  EXPECT_EQ(r.code, 0) << r.out;
  return map;
}

TEST(CliResume, MissingStateFilesAreRefusedAndTheMapIsLeftAlone) {
  for (const char* missing : {"run_state.json", "keyframes.txt"}) {
    chungs::test::TempDir dir;
    const fs::path map = small_map(dir.path());
    ASSERT_TRUE(fs::exists(map / missing));
    fs::remove(map / missing);
    const std::string before = listing(map), manifest = read_all(map / "manifest.txt");
    auto r = run_cli("run --dataset " + kDataset + " --device cpu --no-eval --resume --out " + map.string());
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.out.find(std::string("has no ") + missing), std::string::npos) << r.out;
    EXPECT_EQ(read_all(map / "manifest.txt"), manifest);
    EXPECT_EQ(listing(map), before);
  }
}

TEST(CliResume, DamagedRunStateValuesAreRefusedNamingTheKey) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());
  const std::string state = read_all(map / "run_state.json");
  auto replaced = [&](const std::string& key, const std::string& value) {
    // "key": <value> with the writer's formatting, whatever the old value was.
    const size_t at = state.find("\"" + key + "\"");
    EXPECT_NE(at, std::string::npos) << key;
    const size_t colon = state.find(':', at), end = state.find_first_of(",}\n", colon);
    return state.substr(0, colon + 1) + value + state.substr(end);
  };
  for (const auto& [key, value, says] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"next_frame", "-3", "'next_frame' must be a whole number"},
           {"next_frame", "99999", "'next_frame' 99999 lies beyond"},
           {"seconds", "\"abc\"", "'seconds' must be a finite number"},
           {"iterations", "1.5", "'iterations' must be a whole number"},
           {"finished", "\"yes\"", "'finished' must be true or false"},
           // The map's geometry, which a lost manifest is rebuilt with: out of range, or not the manifest's.
           {"sh_degree", "9", "'sh_degree' must be a whole number in [0, 3]"},
           {"chunk_size", "5", "'chunk_size' 5 differs from the map's 10 m"},
           {"far_level_distance", "-1", "'far_level_distance' must be 0 or a positive number"},
           {"frames", "3", "'next_frame' 12 lies beyond its 'frames' 3"}}) {
    { std::ofstream(map / "run_state.json", std::ios::binary) << replaced(key, value); }
    const std::string before = listing(map);
    auto r = run_cli("run --dataset " + kDataset + " --device cpu --no-eval --resume --out " + map.string());
    EXPECT_NE(r.code, 0) << key << " " << value << "\n" << r.out;
    EXPECT_NE(r.out.find("run_state.json: " + says), std::string::npos) << r.out;
    EXPECT_EQ(listing(map), before) << key;
  }
}

// --resume skipped the check that keeps a new map out of a folder of the user's files: with no map there
// to resume, `run --out ~/notes --resume` wrote a map among them.
TEST(CliResume, AFolderOfOtherFilesIsRefusedWithResumeAsWithout) {
  chungs::test::TempDir dir;
  const auto folder = dir / "notes";
  std::filesystem::create_directories(folder);
  std::ofstream(folder / "a.txt") << "keep";
  const std::string run = "run --dataset synth-street:length=12,width=64,height=48,seed=2 --poses gt --device cpu "
                          "--no-eval --out " + folder.string();
  for (const std::string& more : {"", " --resume"}) {
    auto r = run_cli(run + more);
    EXPECT_EQ(r.code, 1) << more << "\n" << r.out;
    EXPECT_NE(r.out.find("holds files and no map (a.txt)"), std::string::npos) << more << "\n" << r.out;
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(folder)) names.push_back(e.path().filename().string());
    EXPECT_EQ(names, std::vector<std::string>{"a.txt"}) << more;
  }
  // A new or empty folder still takes --resume (a script may always pass it).
  auto r = run_cli(run.substr(0, run.size() - folder.string().size()) + (dir / "fresh").string() + " --resume");
  EXPECT_EQ(r.code, 0) << r.out;
}

TEST(CliResume, AnIntactMapStillResumes) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());
  auto r = run_cli("run --dataset " + kDataset + " --device cpu --no-eval --resume --out " + map.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("resuming"), std::string::npos) << r.out;
}

// A map keeps its chunk size: a different one typed with --resume was ignored without a word.
TEST(CliResume, AnotherChunkSizeIsRefusedNamingTheMapsOwn) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());
  const std::string before = listing(map);
  auto r = run_cli("run --dataset " + kDataset + " --device cpu --no-eval --resume --chunk-size 5 --out " + map.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--chunk-size 5: the map in " + map.string() + " has 10 m chunks"), std::string::npos) << r.out;
  EXPECT_EQ(listing(map), before);
  r = run_cli("run --dataset " + kDataset + " --device cpu --no-eval --resume --chunk-size 10 --out " + map.string());
  EXPECT_EQ(r.code, 0) << r.out;
}

// A map keeps the resolution it was made at: --resume --resolution 0.5 on a full-size map was taken and
// added keyframes at half the size to it.
TEST(CliResume, AnotherResolutionIsRefusedNamingTheMapsOwn) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());
  const std::string before = listing(map);
  const std::string resume = "run --dataset " + kDataset + " --device cpu --no-eval --resume --out " + map.string();
  auto r = run_cli(resume + " --resolution 0.5");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--resolution 0.5: the map in " + map.string() + " was made at resolution 1;"), std::string::npos)
      << r.out;
  EXPECT_EQ(listing(map), before);
  r = run_cli(resume + " --resolution 1");
  EXPECT_EQ(r.code, 0) << r.out;
}

// --resume with other poses than the map's, or fewer frames than it covers, was taken: the first placed
// the rest of the map on another trajectory, the second wrote the smaller count as where the map stood
// (a later --resume mapped those frames again on top of their Gaussians).
TEST(CliResume, OtherPosesOrFewerFramesThanTheMapCoversAreRefused) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());  // 12 frames on ground-truth poses
  fs::copy_file(map / "trajectory.txt", dir / "poses.txt");
  const std::string before = listing(map);
  const std::string resume = "run --dataset " + kDataset + " --device cpu --no-eval --resume --out " + map.string();
  auto r = run_cli(resume + " --poses " + (dir / "poses.txt").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("the map was made on --poses gt, not "), std::string::npos) << r.out;
  EXPECT_EQ(listing(map), before);
  r = run_cli(resume + " --max-frames 5");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--max-frames 5: the map in " + map.string() + " already covers 12 frames"), std::string::npos)
      << r.out;
  EXPECT_EQ(listing(map), before);
  r = run_cli(resume + " --max-frames 12");
  EXPECT_EQ(r.code, 0) << r.out;
}

// A stereo map resumed with one camera's depth: its new keyframes have no depth until their neighbours
// give them some, and a step on one with chunks left out built a 0x0 pixel mask that the loss refused
// ("mapping loss: pixel mask 0x0x1 does not match the 128x64 render").
TEST(CliResume, AStereoMapGoesOnWithMultiviewDepth) {
  chungs::test::TempDir dir;
  const std::string street = "synth-street:length=40,width=128,height=64,seed=2";
  const std::string run = "-q run --dataset " + street + " --poses gt --device cpu --iterations 2 --no-eval --out " +
                          (dir / "map").string();
  auto r = run_cli(run + " --max-frames 20");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_cli(run + " --resume --depth multiview");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("pixel mask"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(dir / "map" / "report.json"));
}

// A corrupt manifest's hint said to delete it so that a writer rebuilds it; `run --resume` then deleted every
// chunk file instead (its roll-back to the last commit found no commit). Now the user's whole path works.
TEST(CliResume, AManifestDeletedAfterItReadBackCorruptIsRebuiltFromTheChunkFiles) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());
  auto exported = [&](const std::string& name) {
    const fs::path ply = dir / name;
    auto r = run_cli("-q export --map " + map.string() + " --out " + ply.string());
    EXPECT_EQ(r.code, 0) << r.out;
    const std::string head = read_all(ply).substr(0, 300);
    const size_t at = head.find("element vertex ");
    return at == std::string::npos ? std::string("none") : head.substr(at, head.find('\n', at) - at);
  };
  const std::string before = exported("before.ply");
  ASSERT_NE(before, "element vertex 0");
  { std::ofstream(map / "manifest.txt", std::ios::app) << "junk\n"; }
  auto r = run_cli("export --map " + map.string() + " --out " + (dir / "x.ply").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("delete it, and `run --resume` rebuilds it from the chunk files"), std::string::npos) << r.out;
  fs::remove(map / "manifest.txt");
  r = run_cli("export --map " + map.string() + " --out " + (dir / "x.ply").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("manifest.txt is missing, though the map's keyframes.txt is there"), std::string::npos) << r.out;
  r = run_cli("run --dataset " + kDataset + " --device cpu --max-frames 12 --no-eval --resume --out " + map.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("manifest.txt is missing; rebuilt it from"), std::string::npos) << r.out;
  EXPECT_EQ(exported("after.ply"), before);
}

// A keyframe list that lost lines (or was emptied) resumed with the keyframes it still named: the others
// were dropped and their images deleted, with exit 0.
TEST(CliResume, AKeyframeListThatLostLinesIsRefusedAndNoKeyframeIsDeleted) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());
  const std::string list = read_all(map / "keyframes.txt");
  std::vector<std::string> lines;
  for (size_t at = 0; at < list.size();) {
    const size_t end = list.find('\n', at);
    lines.push_back(list.substr(at, end - at + 1));
    at = end + 1;
  }
  ASSERT_GE(lines.size(), 6u);  // a header and five keyframes at least
  const std::string header = lines[0];
  std::string without_some = header;
  for (size_t i = 1; i < lines.size(); ++i)
    if (i < 2 || i > 4) without_some += lines[i];
  for (const std::string& damaged : {without_some, header, std::string()}) {
    { std::ofstream(map / "keyframes.txt", std::ios::binary) << damaged; }
    const std::string before = listing(map);
    auto r = run_cli("run --dataset " + kDataset + " --device cpu --no-eval --resume --out " + map.string());
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("keyframes.txt: lists"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("the list is damaged; the map is left as it is"), std::string::npos) << r.out;
    EXPECT_EQ(listing(map), before);
  }
  { std::ofstream(map / "keyframes.txt", std::ios::binary) << list; }
  auto r = run_cli("run --dataset " + kDataset + " --device cpu --max-frames 12 --no-eval --resume --out " + map.string());
  EXPECT_EQ(r.code, 0) << r.out;
}

// A map without far-level chunks yet, its manifest lost: the rebuilt manifest said nothing of the
// distance, so the map was taken for one made before levels and kept one level for good.
TEST(CliResume, AMapRebuiltFromItsChunkFilesKeepsItsFarLevelDistance) {
  chungs::test::TempDir dir;
  const fs::path map = small_map(dir.path());
  ASSERT_NE(read_all(map / "manifest.txt").find("config far_level_distance 70\n"), std::string::npos);
  fs::remove(map / "manifest.txt");
  auto r = run_cli("run --dataset " + kDataset + " --device cpu --max-frames 12 --no-eval --resume --out " + map.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("(one level)"), std::string::npos) << r.out;
  EXPECT_NE(read_all(map / "manifest.txt").find("config far_level_distance 70\n"), std::string::npos)
      << read_all(map / "manifest.txt");
}

// A run that failed before its first checkpoint leaves an empty manifest: the README says a new run may
// use that folder, but it was refused as "already holds a map" (and with --resume took the failed run's
// chunk size).
TEST(CliResume, AFolderARunLeftBeforeItsFirstCheckpointTakesANewRun) {
  chungs::test::TempDir dir;
  const fs::path room = dir / "room", map = dir / "map";
  auto r = run_cli("-q synth room --out " + room.string() + " --frames 6 --width 48 --height 32");
  ASSERT_EQ(r.code, 0) << r.out;
  std::vector<fs::path> frames;
  for (const auto& e : fs::directory_iterator(room / "rgb")) frames.push_back(e.path());
  std::sort(frames.begin(), frames.end());
  const std::string good = read_all(frames[4]);
  { std::ofstream(frames[4], std::ios::binary) << "not a png"; }
  const std::string run = "run --dataset tum:" + room.string() + " --poses gt --device cpu --no-eval --out " + map.string();
  r = run_cli(run + " --chunk-size 4");
  ASSERT_NE(r.code, 0) << r.out;
  ASSERT_TRUE(fs::exists(map / "manifest.txt"));
  ASSERT_FALSE(fs::exists(map / "keyframes.txt"));
  { std::ofstream(frames[4], std::ios::binary) << good; }
  r = run_cli(run);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("before its first checkpoint; starting the map afresh"), std::string::npos) << r.out;
  EXPECT_NE(read_all(map / "manifest.txt").find("chunk_size 10"), std::string::npos) << read_all(map / "manifest.txt");
}

}  // namespace
