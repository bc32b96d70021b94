#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include "chungs/eval/lpips_weights.hpp"
#include "lpips_fixtures.hpp"
#include "memory_limit.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {

void write_bytes(const std::filesystem::path& p, const std::string& b) {
  std::ofstream(p, std::ios::binary).write(b.data(), std::streamsize(b.size()));
}

// The checksum recomputed after an edit, so the reader's structural checks are what is tested.
std::string resealed(std::string b) {
  b.resize(b.size() - 4);
  const uint32_t c = crc32(b.data(), b.size());
  b.append(reinterpret_cast<const char*>(&c), 4);
  return b;
}

void put_u32_at(std::string& b, size_t at, uint32_t v) { std::memcpy(b.data() + at, &v, 4); }

std::string message_reading(const std::filesystem::path& p) {
  try {
    read_lpips_weights(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "(read without error)";
}

// Offset of the first tensor's rank field: magic, version, count, name length, name.
constexpr size_t kFirstRank = 8 + 4 + 4 + 4 + sizeof("features.0.weight") - 1;

}  // namespace

TEST(LpipsWeights, Crc32IsZlibs) {
  EXPECT_EQ(crc32("123456789", 9), 0xCBF43926u);
  EXPECT_EQ(crc32("", 0), 0u);
  EXPECT_EQ(crc32("6789", 4, crc32("12345", 5)), 0xCBF43926u);
}

TEST(LpipsWeights, RoundTripsEveryValue) {
  test::TempDir dir;
  const LpipsWeights w = test::random_lpips_weights(3);
  write_lpips_weights(dir / "w.dclpips", w);
  const LpipsWeights r = read_lpips_weights(dir / "w.dclpips");
  for (size_t l = 0; l < 5; ++l) {
    EXPECT_EQ(r.conv[l].weight, w.conv[l].weight);
    EXPECT_EQ(r.conv[l].bias, w.conv[l].bias);
    EXPECT_EQ(r.lin[l], w.lin[l]);
  }
}

TEST(LpipsWeights, DamageIsAnErrorNamingTheFile) {
  test::TempDir dir;
  const std::string good = lpips_weights_bytes(test::random_lpips_weights(4));
  const auto p = dir / "damaged.dclpips";
  auto expect = [&](const std::string& bytes, const std::string& fragment) {
    write_bytes(p, bytes);
    const std::string m = message_reading(p);
    EXPECT_NE(m.find(p.string()), std::string::npos) << m;
    EXPECT_NE(m.find(fragment), std::string::npos) << m;
  };
  expect(good.substr(0, good.size() / 2), "truncated");
  expect(good.substr(0, 12), "truncated");
  expect(good.substr(0, 3), "not an LPIPS weights file");
  expect("", "not an LPIPS weights file");
  std::string b = good;
  b[0] = 'X';
  expect(b, "not an LPIPS weights file");
  b = good;
  b[good.size() / 2] ^= 0x10;
  expect(b, "checksum");
  b = good;
  put_u32_at(b, 8, 2);
  expect(resealed(b), "version 2");
  b = good;
  put_u32_at(b, 12, 14);
  expect(resealed(b), "14 tensors");
  b = good;
  put_u32_at(b, kFirstRank + 4, 65);  // conv1 with 65 filters
  expect(resealed(b), "shape [65, 3, 11, 11]");
  b = good;
  b[20] = 'g';  // "geatures.0.weight"
  expect(resealed(b), "'geatures.0.weight'");
  expect(resealed(good + "0000"), "bytes after the last tensor");
  expect(std::string(good.begin(), good.end() - 4), "truncated");
  b = good;
  put_u32_at(b, 16, 0xFFFFFFFFu);
  expect(resealed(b), "tensor name of 4294967295 bytes");
  b = good;
  put_u32_at(b, kFirstRank, 0xFFFFFFFFu);
  expect(resealed(b), "4294967295 dimensions");
}

TEST(LpipsWeights, NegativeOrNonFiniteValuesAreRefused) {
  test::TempDir dir;
  LpipsWeights w = test::random_lpips_weights(5);
  w.lin[2][7] = -0.25f;
  write_lpips_weights(dir / "neg.dclpips", w);
  EXPECT_NE(message_reading(dir / "neg.dclpips").find("lin2.weight has a negative weight"), std::string::npos);
  w = test::random_lpips_weights(5);
  w.conv[1].bias[0] = std::nanf("");
  write_lpips_weights(dir / "nan.dclpips", w);
  EXPECT_NE(message_reading(dir / "nan.dclpips").find("features.3.bias holds a non-finite"), std::string::npos);
}

// A 40-byte file declaring a tensor of 2^32 x 2^32 floats: refused before any allocation.
TEST(LpipsWeights, HugeDeclaredSizesInATinyFileAllocateNothing) {
  test::TempDir dir;
  std::string b = lpips_weights_bytes(test::random_lpips_weights(6)).substr(0, kFirstRank);
  const uint32_t dims[] = {4, 0xFFFFFFFFu, 0xFFFFFFFFu, 0xFFFFFFFFu, 0xFFFFFFFFu};
  b.append(reinterpret_cast<const char*>(dims), sizeof dims);
  b += "0000";
  write_bytes(dir / "huge.dclpips", resealed(b));
  const auto run = test::run_with_memory_limit(size_t(64) << 20, [&] { read_lpips_weights(dir / "huge.dclpips"); });
  EXPECT_EQ(run.outcome, "error") << run.describe();
  EXPECT_NE(run.message.find("huge.dclpips"), std::string::npos) << run.describe();

  // The same declared sizes with the expected shape's place taken: the shape check fires; with a
  // matching shape but a short file, the byte count does.
  std::string t = lpips_weights_bytes(test::random_lpips_weights(6));
  t.resize(kFirstRank + 4 + 16 + 100);
  write_bytes(dir / "short.dclpips", t + "0000");
  EXPECT_NE(message_reading(dir / "short.dclpips").find("declares 23232 floats"), std::string::npos)
      << message_reading(dir / "short.dclpips");
}

TEST(LpipsWeights, MissingFileOrFolderIsNamed) {
  test::TempDir dir;
  EXPECT_NE(message_reading(dir / "absent.dclpips").find("absent.dclpips"), std::string::npos);
  EXPECT_NE(message_reading(dir.path()).find("found a folder"), std::string::npos);
}
