// What --resume and render read back from a map folder's keyframes.txt and run_state.json: a damaged
// record or state is refused naming the file (and line or key), never taken as a pose, a camera or
// a frame number.
#include "chungs/mapping/map_state.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/error.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

namespace fs = std::filesystem;

std::string error_reading_records(const fs::path& file, const std::string& record) {
  std::ofstream(file) << "# id frame stamp width height fx fy cx cy tx ty tz qx qy qz qw uses last_loss\n"
                      << "0 0 0 64 48 52.5 52.5 31.5 23.5 0 0 0 0 0 0 1 3 0.1\n"
                      << record << "\n";
  try {
    read_keyframe_records(file);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(KeyframeRecords, AQuaternionThatIsNoRotationIsRefusedNamingTheLine) {
  // A zero quaternion was normalised into NaNs and rendered without a word.
  test::TempDir dir;
  const fs::path file = dir / "keyframes.txt";
  for (const char* q : {"0 0 0 0", "0 0 0 3"}) {
    const std::string e =
        error_reading_records(file, std::string("1 1 0.1 64 48 52.5 52.5 31.5 23.5 1 0 0 ") + q + " 2 0.1");
    EXPECT_NE(e.find(file.string() + ":3: quaternion"), std::string::npos) << q << ": " << e;
  }
}

TEST(KeyframeRecords, AnImageSizeNoImageFileMayHaveIsRefusedNamingTheLine) {
  // 1000000 x 1000000 passed and render ended in "out of memory" with no file named.
  test::TempDir dir;
  const fs::path file = dir / "keyframes.txt";
  const std::string e =
      error_reading_records(file, "1 1 0.1 1000000 1000000 52.5 52.5 31.5 23.5 1 0 0 0 0 0 1 2 0.1");
  EXPECT_NE(e.find(file.string() + ":3: image size 1000000x1000000"), std::string::npos) << e;
  EXPECT_EQ(error_reading_records(file, "1 1 0.1 8192 8192 52.5 52.5 31.5 23.5 1 0 0 0 0 0 1 2 0.1"), "");
}

TEST(RunState, AResumedRunNeedsANextFrameWithinTheDataset) {
  // Without next_frame, --resume started again at frame 0 on top of the map.
  nlohmann::json state = {{"dataset", "tum:x"}, {"poses", "gt"}, {"finished", false}};
  const auto error = [&](size_t frames) -> std::string {
    try {
      resume_frame(state, "map/run_state.json", frames);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error(8).find("map/run_state.json: 'next_frame' is missing"), std::string::npos) << error(8);
  state["next_frame"] = 9;
  EXPECT_NE(error(8).find("map/run_state.json: 'next_frame' 9 lies beyond the dataset's 8 frames"),
            std::string::npos)
      << error(8);
  state["next_frame"] = 8;
  EXPECT_EQ(resume_frame(state, "map/run_state.json", 8), 8u);
}

// A new map's run writes report.json, trajectory.txt, memory.png ... into its folder: a folder of other
// files is refused naming them, and left as it was. New, empty and a run's own leftovers are taken.
TEST(NewMapFolder, AFolderOfOtherFilesIsRefusedNamingThemAndLeftAsItWas) {
  test::TempDir dir;
  EXPECT_NO_THROW(require_folder_for_new_map(dir / "new"));
  fs::create_directories(dir / "empty");
  EXPECT_NO_THROW(require_folder_for_new_map(dir / "empty"));
  // Stopped before its first checkpoint: the store's chunk folder and lock, a numbered keyframe list, a temporary.
  fs::create_directories(dir / "leftover" / "chunks");
  for (const char* f : {"lock", "checkpoint-1-keyframes.txt", "manifest.txt.tmp-12-0", "timeline.csv"})
    std::ofstream(dir / "leftover" / f) << "x";
  EXPECT_NO_THROW(require_folder_for_new_map(dir / "leftover"));
  // The user's files beside a run's names.
  fs::create_directories(dir / "user" / "photos");
  for (const char* f : {"trajectory.txt", "notes.md", "a.txt", "b.txt"}) std::ofstream(dir / "user" / f) << "keep";
  try {
    require_folder_for_new_map(dir / "user");
    FAIL() << "a folder of other files was taken";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("holds files and no map (a.txt, b.txt, notes.md and 1 more)"), std::string::npos) << m;
  }
  // A run's name alone, without the chunk folder a run makes first, is not a run's leftover.
  fs::create_directories(dir / "only_trajectory");
  std::ofstream(dir / "only_trajectory" / "trajectory.txt") << "keep";
  try {
    require_folder_for_new_map(dir / "only_trajectory");
    FAIL() << "a folder holding only the user's trajectory.txt was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("(trajectory.txt)"), std::string::npos) << e.what();
  }
  std::ifstream in(dir / "only_trajectory" / "trajectory.txt");
  std::string kept;
  in >> kept;
  EXPECT_EQ(kept, "keep");
}

}  // namespace
}  // namespace chungs
