#include "chungs/store/chunk_levels.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "chungs/common/error.hpp"
#include "store/random_block.hpp"
#include "store/store_test_configs.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

TEST(ChunkLevels, ANewMapRecordsItsDistanceAndKeepsItWhateverLaterSettingsSay) {
  test::TempDir dir;
  {
    ChunkStore s(dir.path(), test::unflushed_store());
    EXPECT_DOUBLE_EQ(settle_far_level_distance(s, 37.25), 37.25);
    s.save(far_level_of(chunk_id({1, 0, 4})), test::random_block(5, 1, 10, 0, 40));
    s.commit();
  }
  ChunkStore s(dir.path(), test::unflushed_store());
  EXPECT_DOUBLE_EQ(map_far_level_distance(s), 37.25);
  EXPECT_DOUBLE_EQ(settle_far_level_distance(s, 80), 37.25);  // the chunks' levels were chosen at 37.25 m
  EXPECT_DOUBLE_EQ(settle_far_level_distance(s, 0), 37.25);
  EXPECT_TRUE(s.contains(far_level_of(chunk_id({1, 0, 4}))));
  EXPECT_FALSE(s.contains(chunk_id({1, 0, 4})));
}

TEST(ChunkLevels, AMapFromBeforeLevelsStaysOneLevel) {
  test::TempDir dir;
  {
    ChunkStore s(dir.path(), test::unflushed_store());
    s.save(chunk_id({0, 0, 2}), test::random_block(4, 2, 0, 0, 20));
    s.commit();
  }
  ChunkStore s(dir.path(), test::unflushed_store());
  EXPECT_DOUBLE_EQ(map_far_level_distance(s), 0);
  EXPECT_DOUBLE_EQ(settle_far_level_distance(s, 70), 0);
  EXPECT_FALSE(s.config_value(kFarLevelKey).has_value());
}

TEST(ChunkLevels, ADamagedEntryIsRefusedNamingTheManifest) {
  for (const char* bad : {"-3", "abc", "nan", "inf"}) {
    test::TempDir dir;
    {
      ChunkStore s(dir.path(), test::unflushed_store());
      s.set_config(kFarLevelKey, bad);
      s.commit();
    }
    ChunkStore s(dir.path(), test::unflushed_store());
    try {
      map_far_level_distance(s);
      FAIL() << bad;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("manifest.txt"), std::string::npos) << what;
      EXPECT_NE(what.find(kFarLevelKey), std::string::npos) << what;
    }
  }
}

TEST(ChunkLevels, AReaderThatDrawsEverythingSkipsOnlyFarLevelsWithANearTwin) {
  test::TempDir dir;
  ChunkStore s(dir.path(), test::unflushed_store());
  const ChunkId both = chunk_id({0, 0, 1}), far_only = far_level_of(chunk_id({0, 0, 9}));
  s.save(both, test::random_block(3, 3, 0, 0, 10));
  s.save(far_level_of(both), test::random_block(2, 4, 0, 0, 10));
  s.save(far_only, test::random_block(2, 5, 0, 0, 90));
  EXPECT_FALSE(far_level_with_near_twin(s, both));
  EXPECT_TRUE(far_level_with_near_twin(s, far_level_of(both)));
  EXPECT_FALSE(far_level_with_near_twin(s, far_only));
}
