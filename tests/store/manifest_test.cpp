#include <gtest/gtest.h>

#include "chungs/common/error.hpp"
#include "chungs/store/manifest.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {
Manifest sample() {
  Manifest m;
  m.chunk_size = 7.3;
  m.sh_degree = 2;
  m.config["dataset"] = "kitti 02 (stereo)";
  m.config["budget"] = "1500000";
  m.config["empty"] = "";
  for (int i = 0; i < 50; ++i) m.chunks[chunk_id({i - 25, i % 3, -i})] = {uint64_t(i * 100 + 1), uint64_t(i * 7 + 72), uint64_t(i) * 0x9e3779b97f4a7c15ull};
  return m;
}
}  // namespace

TEST(Manifest, RoundTripsThroughFile) {
  test::TempDir dir;
  const Manifest m = sample();
  m.write(dir / "manifest.txt", false);
  const Manifest r = Manifest::read(dir / "manifest.txt");
  EXPECT_EQ(r.chunk_size, m.chunk_size);
  EXPECT_EQ(r.sh_degree, m.sh_degree);
  EXPECT_EQ(r.config, m.config);
  EXPECT_EQ(r.chunks, m.chunks);
  EXPECT_EQ(r.total_gaussians(), m.total_gaussians());
}

TEST(Manifest, RejectsEveryTruncation) {
  const std::string text = sample().serialize();
  for (size_t n = 0; n + 1 < text.size(); n += 13) EXPECT_THROW(Manifest::parse(text.substr(0, n), "m"), Error) << n;
}

TEST(Manifest, RejectsEditedContentWithChecksumError) {
  std::string text = sample().serialize();
  const size_t at = text.find("kitti");
  text[at] = 'K';
  try {
    Manifest::parse(text, "/maps/a/manifest.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/maps/a/manifest.txt: manifest checksum mismatch"), std::string::npos)
        << e.what();
  }
}

TEST(Manifest, RefusesKeysAndValuesThatWouldNotReadBack) {
  Manifest m;
  m.config.emplace("has space", std::string(1, 'x'));
  EXPECT_THROW(m.serialize(), Error);
  m.config.clear();
  m.config.emplace("k", std::string("two\nlines"));
  EXPECT_THROW(m.serialize(), Error);
}
