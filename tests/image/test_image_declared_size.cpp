// A tiny PNG or JPEG whose header declares a huge image is refused, naming the file and the size,
// before the pixels are allocated (a 100-byte PNG declaring 100000x100000 once took 9.8 GB), and a
// depth map must be a 16-bit PNG. The readers run in a child with a bounded address space, so a
// reader that trusts the header fails there with std::bad_alloc instead of the test machine.
#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/image/image_io.hpp"
#include "memory_limit.hpp"
#include "png_bytes.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {

constexpr size_t kChildMemory = size_t(64) << 20;  // far below any of the images declared here

// A real 16x16 JPEG with its frame header (SOF0) changed to declare width x height.
std::string tiny_jpeg(const std::filesystem::path& scratch, uint16_t width, uint16_t height) {
  write_jpeg(scratch, Image8(16, 16, 3, 90));
  std::ifstream in(scratch, std::ios::binary);
  std::string jpg{std::istreambuf_iterator<char>(in), {}};
  const size_t sof = jpg.find("\xff\xc0");
  if (sof == std::string::npos) return {};
  // FF C0, length (2), precision (1), height (2), width (2): big-endian.
  jpg[sof + 5] = char(height >> 8), jpg[sof + 6] = char(height & 0xff);
  jpg[sof + 7] = char(width >> 8), jpg[sof + 8] = char(width & 0xff);
  return jpg;
}

void write_bytes(const std::filesystem::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary) << bytes;
}

void expect_refused(const std::filesystem::path& file, const std::string& size) {
  const auto r = test::run_with_memory_limit(kChildMemory, [&] { read_image8(file); });
  EXPECT_EQ(r.outcome, "error") << r.describe();
  EXPECT_NE(r.message.find(file.filename().string()), std::string::npos) << r.message;
  EXPECT_NE(r.message.find(size), std::string::npos) << r.message;
}

TEST(ImageDeclaredSize, TinyPngDeclaringAHugeImageIsRefusedBeforeAllocating) {
  test::TempDir dir;
  write_bytes(dir / "huge.png", test::png_of_zeros(100000, 100000, 0, 1));  // above any image we read
  expect_refused(dir / "huge.png", "100000 x 100000");
  write_bytes(dir / "big.png",
              test::png_of_zeros(8000, 8000, 2, 1));  // a plausible size, but not from 100 bytes
  expect_refused(dir / "big.png", "8000 x 8000");
}

TEST(ImageDeclaredSize, TinyJpegDeclaringAHugeImageIsRefusedBeforeAllocating) {
  test::TempDir dir;
  const std::string huge = tiny_jpeg(dir / "scratch.jpg", 60000, 60000);
  ASSERT_FALSE(huge.empty());
  write_bytes(dir / "huge.jpg", huge);
  expect_refused(dir / "huge.jpg", "60000 x 60000");
  write_bytes(dir / "big.jpg", tiny_jpeg(dir / "scratch.jpg", 8000, 8000));
  expect_refused(dir / "big.jpg", "8000 x 8000");
}

TEST(ImageDeclaredSize, LargestAcceptedSizesStillRead) {
  test::TempDir dir;
  // A flat 4096x4096 image compresses far beyond a photo: both formats must still read it.
  const Image8 flat(4096, 4096, 3, 77);
  write_png(dir / "flat.png", flat);
  write_jpeg(dir / "flat.jpg", flat);
  // zlib's best on zeros comes within 0.3 % of deflate's limit, which the reader allows for.
  write_bytes(dir / "zeros.png", test::png_of_zeros(4096, 4096, 0, 4096));
  EXPECT_EQ(read_image8(dir / "zeros.png").width(), 4096);
  for (const char* name : {"flat.png", "flat.jpg"}) {
    const Image8 back = read_image8(dir / name);
    EXPECT_TRUE(back.same_shape(flat)) << name;
  }
}

TEST(ImageDeclaredSize, DepthMustBeA16BitPng) {
  test::TempDir dir;
  write_png(dir / "depth8.png", Image8(8, 6, 1, 200));
  try {
    read_png16(dir / "depth8.png");
    FAIL() << "an 8-bit PNG was read as 16-bit depth";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("depth8.png"), std::string::npos) << msg;
    EXPECT_NE(msg.find("16-bit"), std::string::npos) << msg;
  }
}

}  // namespace
