#include <gtest/gtest.h>

#include <fstream>
#include <random>

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
