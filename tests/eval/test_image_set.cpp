#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <random>

#include "chungs/eval/image_set.hpp"
#include "chungs/eval/report.hpp"
#include "chungs/image/image_io.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {

Image8 random_image8(int w, int h, int c, std::mt19937& rng) {
  std::uniform_int_distribution<int> u(0, 255);
  Image8 img(w, h, c);
  for (auto& v : img.vec()) v = uint8_t(u(rng));
  return img;
}

Image8 perturbed(const Image8& img, std::mt19937& rng) {
  std::uniform_int_distribution<int> d(-20, 20);
  Image8 out = img;
  for (auto& v : out.vec()) v = uint8_t(std::clamp(int(v) + d(rng), 0, 255));
  return out;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(ImageSet, PairsFoldersByStemAndScoresEachPair) {
  std::mt19937 rng(31);
  test::TempDir dir;
  Image8 a = random_image8(40, 30, 3, rng), b = random_image8(40, 30, 3, rng);
  write_png(dir / "ref/frame000.png", a);
  write_jpeg(dir / "ref/frame001.jpg", b);
  write_png(dir / "test/frame000.png", perturbed(a, rng));
  write_png(dir / "test/frame001.png", perturbed(read_image8(dir / "ref/frame001.jpg"), rng));
  std::ofstream(dir / "test/notes.txt") << "not an image\n";

  auto pairs = match_image_pairs(dir / "ref", dir / "test");
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].name, "frame000");
  EXPECT_EQ(pairs[1].test.filename(), "frame001.png");
  ImageSetResult r = evaluate_image_pairs(pairs);
  ASSERT_EQ(r.images.size(), 2u);
  double sum_psnr = 0, sum_ssim = 0;
  for (const auto& im : r.images) {
    ImageMetrics direct = compare_images(read_image8(im.pair.ref), read_image8(im.pair.test));
    EXPECT_DOUBLE_EQ(im.metrics.psnr, direct.psnr);
    EXPECT_DOUBLE_EQ(im.metrics.ssim, direct.ssim);
    sum_psnr += direct.psnr, sum_ssim += direct.ssim;
  }
  EXPECT_NEAR(r.mean_psnr, sum_psnr / 2, 1e-12);
  EXPECT_NEAR(r.mean_ssim, sum_ssim / 2, 1e-12);
  EXPECT_EQ(r.infinite_psnr, 0u);
}

// A sequence folder with colour and depth side by side (3DMatch: frame-N.color.png, frame-N.depth.png):
// `eval depth` takes the images named "depth", `eval images` the others; a folder of one kind is
// taken whole, whatever the role.
TEST(ImageSet, AFolderOfColourAndDepthGivesEachRoleItsOwnImages) {
  std::mt19937 rng(5);
  test::TempDir dir;
  for (const char* n : {"frame-000000", "frame-000001"}) {
    write_png(dir / "seq" / (std::string(n) + ".color.png"), random_image8(24, 16, 3, rng));
    write_png(dir / "seq" / (std::string(n) + ".depth.png"), random_image8(24, 16, 1, rng));
    write_png(dir / "renders" / (std::string(n) + ".color.png"), random_image8(24, 16, 3, rng));
  }
  auto depth = match_image_pairs(dir / "seq", dir / "seq", ImageRole::Depth);
  ASSERT_EQ(depth.size(), 2u);
  for (const ImagePair& p : depth) EXPECT_NE(p.name.find(".depth"), std::string::npos) << p.name;
  auto colour = match_image_pairs(dir / "seq", dir / "renders", ImageRole::Colour);
  ASSERT_EQ(colour.size(), 2u);
  for (const ImagePair& p : colour) EXPECT_NE(p.name.find(".color"), std::string::npos) << p.name;
  EXPECT_EQ(match_image_pairs(dir / "seq", dir / "seq").size(), 4u);  // Any: every image
  // Against renders without depth images, the colour role pairs; Any names the depth images missing.
  EXPECT_NE(message_of([&] { match_image_pairs(dir / "seq", dir / "renders"); }).find("missing"), std::string::npos);
  EXPECT_EQ(match_image_pairs(dir / "renders", dir / "renders", ImageRole::Depth).size(), 2u);
}

TEST(ImageSet, SingleFilesAndIdenticalPairReportNullPsnr) {
  std::mt19937 rng(32);
  test::TempDir dir;
  Image8 a = random_image8(24, 20, 3, rng);
  write_png(dir / "a.png", a);
  write_png(dir / "b.png", a);
  auto pairs = match_image_pairs(dir / "a.png", dir / "b.png");
  ASSERT_EQ(pairs.size(), 1u);
  ImageSetResult r = evaluate_image_pairs(pairs);
  EXPECT_EQ(r.infinite_psnr, 1u);
  nlohmann::json j = to_json(r);
  EXPECT_TRUE(j["mean_psnr"].is_null());
  EXPECT_TRUE(j["images"][0]["psnr"].is_null());
  EXPECT_NEAR(j["mean_ssim"].get<double>(), 1.0, 1e-6);
  write_json(dir / "out/report.json", j);
  std::ifstream in(dir / "out/report.json");
  EXPECT_EQ(nlohmann::json::parse(in), j);
}

TEST(ImageSet, ErrorsNameTheFileAtFault) {
  std::mt19937 rng(33);
  test::TempDir dir;
  write_png(dir / "ref/x.png", random_image8(30, 20, 3, rng));
  write_png(dir / "ref/y.png", random_image8(30, 20, 3, rng));
  write_png(dir / "test/x.png", random_image8(30, 20, 3, rng));
  std::string msg = message_of([&] { match_image_pairs(dir / "ref", dir / "test"); });
  EXPECT_NE(msg.find("y"), std::string::npos) << msg;
  EXPECT_NE(msg.find("missing"), std::string::npos) << msg;

  write_png(dir / "test/y.png", random_image8(31, 20, 3, rng));
  auto pairs = match_image_pairs(dir / "ref", dir / "test");
  msg = message_of([&] { evaluate_image_pairs(pairs); });
  EXPECT_NE(msg.find((dir / "test/y.png").string()), std::string::npos) << msg;

  write_png(dir / "test/z.png", random_image8(30, 20, 3, rng));  // extra on the test side
  msg = message_of([&] { match_image_pairs(dir / "ref", dir / "test"); });
  EXPECT_NE(msg.find("z"), std::string::npos) << msg;

  write_jpeg(dir / "ref/x.jpg", random_image8(30, 20, 3, rng));  // two files named x
  msg = message_of([&] { match_image_pairs(dir / "ref", dir / "test"); });
  EXPECT_NE(msg.find("same name"), std::string::npos) << msg;

  EXPECT_THROW(match_image_pairs(dir / "ref", dir / "test/x.png"), Error);
  EXPECT_THROW(match_image_pairs(dir / "nope", dir / "test"), Error);
  std::filesystem::create_directories(dir / "empty1");
  std::filesystem::create_directories(dir / "empty2");
  EXPECT_THROW(match_image_pairs(dir / "empty1", dir / "empty2"), Error);
}

TEST(ImageSet, MaskFileKeepsPixelsWithAnyNonZeroChannel) {
  std::mt19937 rng(34);
  test::TempDir dir;
  Image8 m(30, 20, 3, 0);
  m(3, 4, 2) = 7;
  m(10, 11, 0) = 255;
  write_png(dir / "mask.png", m);
  Image8 mask = read_mask(dir / "mask.png");
  ASSERT_EQ(mask.channels(), 1);
  EXPECT_EQ(mask(3, 4), 255);
  EXPECT_EQ(mask(10, 11), 255);
  EXPECT_EQ(mask(0, 0), 0);
  size_t kept = 0;
  for (auto v : mask.vec()) kept += v != 0;
  EXPECT_EQ(kept, 2u);

  Image8 a = random_image8(30, 20, 3, rng);
  write_png(dir / "r/a.png", a);
  write_png(dir / "t/a.png", perturbed(a, rng));
  ImageSetResult r = evaluate_image_pairs(match_image_pairs(dir / "r", dir / "t"), &mask);
  EXPECT_EQ(r.images[0].metrics.pixels, 2u);
  Image8 small(10, 10, 1, 1);
  EXPECT_THROW(evaluate_image_pairs(match_image_pairs(dir / "r", dir / "t"), &small), Error);
}

TEST(Report, TrajectoryResultsSerialise) {
  ErrorStats s = error_stats({0.1, 0.2, 0.4});
  nlohmann::json j = to_json(s);
  EXPECT_DOUBLE_EQ(j["max"].get<double>(), 0.4);
  EXPECT_EQ(j["count"].get<int>(), 3);
  AteResult ate;
  ate.align = Alignment::Sim3;
  ate.alignment.s = 2.0;
  ate.pairs = {{0, 0}, {1, 1}, {2, 2}};
  ate.errors = {0.1, 0.2, 0.4};
  ate.stats = s;
  nlohmann::json ja = to_json(ate, true);
  EXPECT_EQ(ja["alignment"], "sim3");
  EXPECT_EQ(ja["matched"].get<int>(), 3);
  EXPECT_DOUBLE_EQ(ja["transform"]["scale"].get<double>(), 2.0);
  EXPECT_EQ(ja["errors"].size(), 3u);
  EXPECT_FALSE(to_json(ate).contains("errors"));
  EXPECT_TRUE(json_number(std::numeric_limits<double>::quiet_NaN()).is_null());
}

TEST(ImageSet, AFifoOrFolderNamedLikeAnImageIsRefusedByItsName) {
  // Skipped before, so its partner reported "test/y.*: missing" for a file that was there.
  std::mt19937 rng(34);
  test::TempDir dir;
  write_png(dir / "ref/y.png", random_image8(30, 20, 3, rng));
  std::filesystem::create_directories(dir / "test");
  ASSERT_EQ(::mkfifo((dir / "test/y.png").c_str(), 0600), 0);
  std::string msg = message_of([&] { match_image_pairs(dir / "ref", dir / "test"); });
  EXPECT_NE(msg.find("test/y.png: expected a PNG or JPEG image, found a FIFO"), std::string::npos) << msg;
  std::filesystem::remove(dir / "test/y.png");
  std::filesystem::create_directories(dir / "test/y.png");
  msg = message_of([&] { match_image_pairs(dir / "ref", dir / "test"); });
  EXPECT_NE(msg.find("test/y.png: expected a PNG or JPEG image, found a folder"), std::string::npos) << msg;
}
