#include "chungs/store/map_folder.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/store/chunk_store.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
std::string refusal(const std::filesystem::path& folder) {
  try {
    require_map_manifest(folder);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

// A reader's refusal says what to do: a folder that is no map says so; a map that lost its manifest
// (its keyframe list still there) is told how a writer rebuilds it.
TEST(MapFolder, ReadersNameAMissingManifestAndHowAMapThatLostItIsRebuilt) {
  test::TempDir dir;
  EXPECT_NE(refusal(dir.path()).find("not a map folder (no manifest.txt)"), std::string::npos);
  std::ofstream(dir.path() / "keyframes.txt") << "# id frame stamp\n";
  const std::string lost = refusal(dir.path());
  EXPECT_NE(lost.find("manifest.txt is missing"), std::string::npos) << lost;
  EXPECT_NE(lost.find("run --resume"), std::string::npos) << lost;
  { ChunkStore s(dir.path()); }  // a writer's open commits a manifest (an empty map)
  EXPECT_EQ(refusal(dir.path()), "");
  std::filesystem::remove(dir.path() / "manifest.txt");
  try {
    const ChunkStore s(dir.path(), reader_config());
    ADD_FAILURE() << "a reader opened a folder without a manifest";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("run --resume"), std::string::npos) << e.what();
  }
}
