#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/store/keyframe_store.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
KeyframeImages random_keyframe(int w, int h, uint32_t seed, bool depth = true) {
  std::mt19937 rng(seed);
  KeyframeImages k;
  k.color = Image8(w, h, 3);
  for (auto& v : k.color.vec()) v = uint8_t(rng());
  if (depth) {
    k.depth = ImageF(w, h, 1);
    std::uniform_real_distribution<float> d(0.5f, 80.f);
    for (auto& v : k.depth.vec()) v = d(rng);
  }
  return k;
}
KeyframeStoreConfig small(size_t n, bool compress = true) {
  KeyframeStoreConfig c;
  c.max_in_memory = n;
  c.compress = compress;
  c.durable = false;
  return c;
}
}  // namespace

TEST(KeyframeStore, RoundTripsImagesAndDepthThroughDisk) {
  test::TempDir dir;
  for (bool compress : {false, true}) {
    const KeyframeImages a = random_keyframe(37, 21, 1), b = random_keyframe(16, 9, 2, false);
    {
      KeyframeStore s(dir / (compress ? "z" : "raw"), small(4, compress));
      s.put(7, a);
      s.put(1234567890123ull, b);
    }
    KeyframeStore s(dir / (compress ? "z" : "raw"), small(4, compress));
    EXPECT_EQ(s.ids(), (std::vector<uint64_t>{7, 1234567890123ull}));
    EXPECT_EQ(s.in_memory(), 0u);
    const auto ra = s.get(7), rb = s.get(1234567890123ull);
    EXPECT_EQ(ra->color.vec(), a.color.vec());
    EXPECT_EQ(ra->depth.vec(), a.depth.vec());
    EXPECT_EQ(ra->color.width(), 37);
    EXPECT_EQ(rb->color.vec(), b.color.vec());
    EXPECT_TRUE(rb->depth.empty());
    EXPECT_EQ(s.counters().snapshot().loads, 2u);
  }
}

TEST(KeyframeStore, KeepsAtMostNInMemoryDroppingTheLeastRecentlyUsed) {
  test::TempDir dir;
  KeyframeStore s(dir.path(), small(3));
  for (uint64_t i = 0; i < 5; ++i) s.put(i, random_keyframe(8, 8, uint32_t(i)));
  s.commit();  // written: only the cache holds keyframes in memory now
  EXPECT_EQ(s.in_memory(), 3u);
  EXPECT_FALSE(s.is_in_memory(0));
  EXPECT_FALSE(s.is_in_memory(1));
  s.get(2);  // 2 becomes most recent; 3 is now the oldest
  s.get(0);  // loads from disk, drops 3
  EXPECT_TRUE(s.is_in_memory(2));
  EXPECT_TRUE(s.is_in_memory(0));
  EXPECT_FALSE(s.is_in_memory(3));
  EXPECT_EQ(s.in_memory(), 3u);
  EXPECT_EQ(s.counters().snapshot().loads, 1u);
  // Dropped keyframes come back intact.
  EXPECT_EQ(s.get(3)->color.vec(), random_keyframe(8, 8, 3).color.vec());
}

TEST(KeyframeStore, ImagesStayValidAfterTheCacheDropsThem) {
  test::TempDir dir;
  KeyframeStore s(dir.path(), small(1));
  s.put(1, random_keyframe(8, 8, 1));
  const auto held = s.get(1);
  s.put(2, random_keyframe(8, 8, 2));
  s.commit();
  EXPECT_FALSE(s.is_in_memory(1));
  EXPECT_EQ(held->color.vec(), random_keyframe(8, 8, 1).color.vec());
}

TEST(KeyframeStore, EraseRemovesFileAndMissingKeyframeIsAnError) {
  test::TempDir dir;
  KeyframeStore s(dir.path(), small(2));
  s.put(5, random_keyframe(4, 4, 5));
  s.erase(5);
  EXPECT_FALSE(s.contains(5));
  EXPECT_FALSE(fs::exists(s.path_of(5)));
  try {
    s.get(5);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 5"), std::string::npos) << e.what();
  }
}

TEST(KeyframeStore, RejectsACorruptFileNamingIt) {
  test::TempDir dir;
  fs::path p;
  {
    KeyframeStore s(dir.path(), small(2, false));
    s.put(3, random_keyframe(20, 20, 3));
    p = s.path_of(3);
  }
  {
    std::fstream f(p, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(300);
    f.put('\x01');
  }
  KeyframeStore s(dir.path(), small(2, false));
  try {
    s.get(3);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
  }
}

TEST(KeyframeStore, WritesRunBehindUntilACommitFlushesThemAll) {
  test::TempDir dir;
  KeyframeStoreConfig c = small(2);
  c.durable = true;
  {
    KeyframeStore s(dir.path(), c);
    for (uint64_t i = 0; i < 6; ++i) s.put(i, random_keyframe(16, 8, uint32_t(i)));
    // Not yet written ones are served from memory, never lost from it.
    for (uint64_t i = 0; i < 6; ++i) EXPECT_EQ(s.get(i)->color.vec(), random_keyframe(16, 8, uint32_t(i)).color.vec());
    s.commit();
    const IoStats st = s.counters().snapshot();
    EXPECT_EQ(st.saves, 6u);
    EXPECT_EQ(st.barriers, 1u);
    EXPECT_EQ(st.synced_files, 6u);
    for (uint64_t i = 0; i < 6; ++i) EXPECT_TRUE(fs::exists(s.path_of(i)));
    s.commit();  // nothing new: nothing flushed again
    EXPECT_EQ(s.counters().snapshot().synced_files, 6u);
  }
  KeyframeStore again(dir.path(), c);
  EXPECT_EQ(again.size(), 6u);
  EXPECT_EQ(again.get(5)->depth.vec(), random_keyframe(16, 8, 5).depth.vec());
}

TEST(KeyframeStore, ReadAheadSparesTheCallerTheDiskRead) {
  test::TempDir dir;
  KeyframeStore s(dir.path(), small(1));
  s.put(1, random_keyframe(8, 8, 1));
  s.put(2, random_keyframe(8, 8, 2));
  s.commit();
  ASSERT_FALSE(s.is_in_memory(1));
  s.prefetch(1);
  for (int t = 0; t < 400 && !s.is_in_memory(1); ++t) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(s.get(1)->color.vec(), random_keyframe(8, 8, 1).color.vec());
  const IoStats st = s.counters().snapshot();
  EXPECT_EQ(st.loads, 1u);
  EXPECT_EQ(st.sync_loads, 0u);
  s.get(2);  // dropped for 1 and not read ahead: read on the caller's thread
  EXPECT_EQ(s.counters().snapshot().sync_loads, 1u);
}

TEST(KeyframeStore, AFailedBackgroundWriteFailsEveryLaterWriteAndCommit) {
  test::TempDir dir;
  KeyframeStore s(dir / "kf", small(4));
  fs::remove_all(dir / "kf");  // the folder vanishes under the store: writes fail
  s.put(9, random_keyframe(8, 8, 9));
  EXPECT_THROW(s.commit(), Error);
  EXPECT_THROW(s.put(10, random_keyframe(8, 8, 10)), Error);  // and every later write
  EXPECT_EQ(s.get(9)->color.vec(), random_keyframe(8, 8, 9).color.vec());  // still held in memory
}

// The caller reports what it was thrown (the CLI prints one error line); a second report of the same
// failure when the store closes would read as a second fault.
TEST(KeyframeStore, AFailedWriteThatACallerWasToldOfIsNotLoggedAgainOnClose) {
  test::TempDir dir;
  testing::internal::CaptureStderr();
  {
    KeyframeStore s(dir / "kf", small(4));
    fs::remove_all(dir / "kf");
    s.put(9, random_keyframe(8, 8, 9));
    EXPECT_THROW(s.commit(), Error);
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  testing::internal::CaptureStderr();
  {
    KeyframeStore s(dir / "kf2", small(4));
    fs::remove_all(dir / "kf2");
    s.put(9, random_keyframe(8, 8, 9));  // fails behind; nobody asks again
  }
  EXPECT_NE(testing::internal::GetCapturedStderr().find("kf2"), std::string::npos);
}

TEST(KeyframeStore, WritesOnTheCallersThreadWhenAskedTo) {
  test::TempDir dir;
  KeyframeStoreConfig c = small(1);
  c.background = false;
  KeyframeStore s(dir.path(), c);
  s.put(1, random_keyframe(8, 8, 1));
  EXPECT_TRUE(fs::exists(s.path_of(1)));  // written before put returned
  s.put(2, random_keyframe(8, 8, 2));
  EXPECT_EQ(s.get(1)->color.vec(), random_keyframe(8, 8, 1).color.vec());
  EXPECT_EQ(s.counters().snapshot().sync_loads, 1u);
}
