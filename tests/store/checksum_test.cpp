#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "chungs/store/checksum.hpp"

using namespace chungs;

// Reference values computed with the system's libxxhash (0.8.1) over bytes (7 i + 3) mod 256.
TEST(Checksum, MatchesReferenceXxh64) {
  std::vector<uint8_t> data(200);
  for (size_t i = 0; i < data.size(); ++i) data[i] = uint8_t((i * 7 + 3) & 255);
  struct Case {
    size_t n;
    uint64_t seed0, seed12345;
  };
  const Case cases[] = {{0, 0xef46db3751d8e999, 0x95584af7701f808d},  {1, 0x1f25c8d0bc1f4bb6, 0x9102786a712ff044},
                        {3, 0x31d2363f52e564c9, 0xc6270ec97f034479},  {4, 0x9bb64b7d66ee9fda, 0x6a3181371bbc2026},
                        {7, 0x9a7b149959ce60d8, 0x6e596c9ec41c4637},  {8, 0xdab99d95c6f90092, 0xbbcc4601a016b1e4},
                        {31, 0xa2aa5f33cc4a6119, 0x8086bf60119a7308}, {32, 0x23c3c17ef790fd97, 0x244c3905cf320c2d},
                        {33, 0x50a7cfc7ba588784, 0x1edc993457cf1fd8}, {63, 0x5e3e54b431c7493c, 0x0e4a6a50d61e6220},
                        {64, 0x0eb64b3ef6eeb01f, 0xef589281222c0318}, {100, 0xa61f8d4c170fe531, 0xacb8a02891fea7d2},
                        {200, 0xa6cb3c09bc829b24, 0x9011d9d779932d3b}};
  for (const auto& c : cases) {
    EXPECT_EQ(xxh64(data.data(), c.n), c.seed0) << "length " << c.n;
    EXPECT_EQ(xxh64(data.data(), c.n, 12345), c.seed12345) << "length " << c.n;
  }
  EXPECT_EQ(xxh64("abc", 3), 0x44bc2cf5ad770999ull);
}

TEST(Checksum, StreamingInRandomPiecesEqualsOneShot) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<uint8_t> data(rng() % 3000);
    for (auto& b : data) b = uint8_t(rng());
    Xxh64 h(trial);
    size_t at = 0;
    while (at < data.size()) {
      const size_t n = std::min<size_t>(data.size() - at, rng() % 70);
      h.update(data.data() + at, n);
      at += n;
    }
    EXPECT_EQ(h.digest(), xxh64(data.data(), data.size(), trial));
  }
}

TEST(Checksum, DetectsSingleBitFlips) {
  std::vector<uint8_t> data(1000, 0x5a);
  const uint64_t ref = xxh64(data.data(), data.size());
  for (size_t i = 0; i < data.size(); i += 37) {
    data[i] ^= 1;
    EXPECT_NE(xxh64(data.data(), data.size()), ref);
    data[i] ^= 1;
  }
}
