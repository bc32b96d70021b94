#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/image/image_io.hpp"
#include "test_support.hpp"

using namespace chungs;

TEST(ImageIO, Png8And16RoundTripExactly) {
  test::TempDir dir;
  std::mt19937 rng(8);
  for (int ch : {1, 3, 4}) {
    Image8 img(37, 23, ch);
    for (auto& v : img.vec()) v = uint8_t(rng());
    write_png(dir / "a.png", img);
    Image8 back = read_image8(dir / "a.png");
    ASSERT_TRUE(back.same_shape(img));
    EXPECT_EQ(back.vec(), img.vec());
  }
  Image16 d(41, 19, 1);
  for (auto& v : d.vec()) v = uint16_t(rng());
  write_png(dir / "d.png", d);
  Image16 back = read_png16(dir / "d.png");
  EXPECT_EQ(back.vec(), d.vec());
}

TEST(ImageIO, JpegRoundTripIsClose) {
  test::TempDir dir;
  Image8 img(64, 48, 3);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x)
      for (int c = 0; c < 3; ++c) img(x, y, c) = uint8_t((x * 3 + y * 2 + c * 40) % 256 / 2 + 60);
  write_jpeg(dir / "a.jpg", img, 95);
  Image8 back = read_image8(dir / "a.jpg");
  ASSERT_TRUE(back.same_shape(img));
  double err = 0;
  for (size_t i = 0; i < img.size(); ++i) err += std::abs(int(img.data()[i]) - int(back.data()[i]));
  EXPECT_LT(err / img.size(), 3.0);
}

TEST(ImageIO, CorruptAndMissingFilesNameTheFile) {
  test::TempDir dir;
  Image8 img(32, 32, 1, 7);
  write_png(dir / "ok.png", img);
  std::string bytes;
  {
    std::ifstream in(dir / "ok.png", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(dir / "trunc.png", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(dir / "text.png") << "hello";
  for (const char* name : {"trunc.png", "text.png", "missing.png"}) {
    try {
      read_image8(dir / name);
      FAIL() << name;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
}

TEST(ImageIO, ReadsRealDatasetImages) {
  CHUNGS_REQUIRE_DATA("kitti_seq1");
  Image8 k = read_image8(test::shared_data("kitti_seq1/image_l/000000.png"));
  EXPECT_EQ(k.width(), 1226);
  EXPECT_EQ(k.height(), 370);
  EXPECT_EQ(k.channels(), 1);
  CHUNGS_REQUIRE_DATA("replica_office0");
  Image8 j = read_image8(test::shared_data("replica_office0/office0/results/frame000000.jpg"));
  EXPECT_EQ(j.channels(), 3);
  Image16 d = read_png16(test::shared_data("replica_office0/office0/results/depth000000.png"));
  EXPECT_EQ(d.width(), 1200);
  size_t valid = 0;
  for (auto v : d.vec()) valid += v > 0;
  EXPECT_GT(valid, d.size() / 2);
}

TEST(Image, ConversionsRoundTrip) {
  Image8 img(5, 4, 3);
  for (size_t i = 0; i < img.size(); ++i) img.data()[i] = uint8_t(i * 11);
  EXPECT_EQ(to_u8(to_float(img)).vec(), img.vec());
  ImageF g = to_gray(to_float(img));
  EXPECT_EQ(g.channels(), 1);
  EXPECT_NEAR(g(1, 1), (0.299f * img(1, 1, 0) + 0.587f * img(1, 1, 1) + 0.114f * img(1, 1, 2)) / 255.f, 1e-6);
  EXPECT_THROW(Image8(3, 3, 5), Error);
}

// Each output pixel the rounded mean of its block's part inside the image, against a double reference
// on random pixels; partial blocks at the right and bottom edges, and a block wholly outside gives 0.
TEST(Image, BoxDownscaleAveragesEachBlocksPartInsideTheImage) {
  std::mt19937 rng(7);
  Image8 img(11, 7, 3);
  for (auto& v : img.vec()) v = uint8_t(rng());
  const Image8 out = box_downscale(img, 4, 3, 2);
  ASSERT_EQ(out.width(), 3);
  ASSERT_EQ(out.height(), 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        int n = 0;
        for (int yy = 4 * y; yy < std::min(4 * y + 4, 7); ++yy)
          for (int xx = 4 * x; xx < std::min(4 * x + 4, 11); ++xx) sum += img(xx, yy, c), ++n;
        EXPECT_NEAR(out(x, y, c), sum / n, 0.5 + 1e-9) << x << "," << y << "," << c;
      }
  EXPECT_EQ(box_downscale(img, 4, 4, 1)(3, 0), 0);
}

// libpng's writer reported a full disk as "PNG write failed (Write Error)": the reason was lost.
TEST(ImageIO, AFailedPngWriteGivesTheSystemsReason) {
  test::TempDir dir;
  std::filesystem::create_symlink("/dev/full", dir / "full.png");
  std::mt19937 rng(5);
  Image8 noise(256, 256, 3);  // compresses to more than the stdio buffer: written while encoding
  for (auto& v : noise.vec()) v = uint8_t(rng());
  try {
    write_png(dir / "full.png", noise);
    FAIL() << "a write to a full disk went unnoticed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("full.png: PNG write failed (No space left on device)"), std::string::npos)
        << e.what();
  }
}
