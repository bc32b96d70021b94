#include "chungs/store/manifest.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "chungs/common/error.hpp"
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

TEST(Manifest, ACountNoChunkMayHoldIsRefusedNamingTheLine) {
  // 2^64 - 1 Gaussians passed, and render printed "18446744073709551615 Gaussians".
  Manifest m = sample();
  m.chunks.begin()->second.count = ~uint64_t(0);
  try {
    Manifest::parse(m.serialize(), "/maps/a/manifest.txt");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/maps/a/manifest.txt:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("18446744073709551615"), std::string::npos) << e.what();
  }
}

TEST(Manifest, AFifoIsRefusedByNameInsteadOfBlockingTheRead) {
  test::TempDir dir;
  const std::filesystem::path fifo = dir / "manifest.txt";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  // Without the check the read blocks until a writer comes: this one comes after a second, opens
  // without blocking (it fails at once where no reader waits) and closes, so the read ends at EOF.
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 0; i < 100 && !done; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
  });
  const auto t0 = std::chrono::steady_clock::now();
  std::string what;
  try {
    Manifest::read(fifo);
  } catch (const Error& e) {
    what = e.what();
  }
  done = true;
  writer.join();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500))
      << "the read waited for a writer";
  EXPECT_NE(what.find(fifo.string() + ": expected a file, found a FIFO"), std::string::npos) << what;
}
